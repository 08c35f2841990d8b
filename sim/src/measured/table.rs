//! Property tables as labs publish them: two columns per line, a temperature and a value
//! (comma or space separated), in ascending temperature; lines starting with `#` are comments.

use super::{at_line, fields};
use crate::error::{Error, Result};

/// (T, value) rows as written; `file` names the file in messages.
pub fn rows(text: &str, file: &str) -> Result<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let f = fields(line);
        if f.is_empty() || line.trim_start().starts_with('#') {
            continue;
        }
        let pair = (f.len() == 2)
            .then(|| Some((f[0].parse::<f64>().ok()?, f[1].parse::<f64>().ok()?)))
            .flatten()
            .filter(|(t, v)| t.is_finite() && v.is_finite());
        match pair {
            Some(p) => out.push(p),
            None => {
                return Err(at_line(
                    file,
                    k + 1,
                    format!(
                        "{:?}; expected two numbers: a temperature and a value",
                        line.trim()
                    ),
                ));
            }
        }
    }
    if out.is_empty() {
        return Err(Error::input(format!(
            "{file}: no rows; expected a property table"
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    #[test]
    fn two_numbers_a_line() {
        let r = super::rows("# T K, cp J/g/K\n298    0.435\n373,0.455\n", "cp.txt").unwrap();
        assert_eq!(r, vec![(298.0, 0.435), (373.0, 0.455)]);
        let e = super::rows("298 0.4 1\n", "cp.txt").unwrap_err();
        assert!(e.message.contains("cp.txt line 1"), "{}", e.message);
    }
}
