//! A `plan` or `dwell` run's path.csv read back as a program (issue 29, item 3): per path
//! point where it is, its layer, and how it was laid — the dwell before it, its pace, its part
//! in a drop (docs/INTERFACE: `drop` 0 a running torch, 1 a drop strikes, 2 the drop goes on).

use super::{at_line, fields};
use crate::error::{Error, Result};

/// One path point as laid.
#[derive(Debug, Clone, PartialEq)]
pub struct PathRow {
    pub position_mm: [f64; 3],
    pub layer: usize,
    pub dwell_s: f64,
    /// Wire feed and travel speed divided by it (1: as planned).
    pub pace: f64,
    /// 0, 1 or 2, as the column says.
    pub drop: u8,
}

/// The rows of a path.csv; `file` names it in messages. `pace` and `drop` may be absent (a
/// `plan` run's: 1 and 0); the others must be there.
pub fn rows(text: &str, file: &str) -> Result<Vec<PathRow>> {
    let mut lines = text.lines().enumerate();
    let header: Vec<&str> = lines.next().map(|(_, l)| fields(l)).unwrap_or_default();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let need = |name: &str| {
        col(name).ok_or_else(|| {
            Error::input(format!(
                "{file} line 1: no column `{name}`; expected a plan or dwell run's path.csv \
                 (i,x,y,z,...,layer,...,dwell_s)"
            ))
        })
    };
    let (ci, cx, cy, cz, cl, cd) = (
        need("i")?,
        need("x")?,
        need("y")?,
        need("z")?,
        need("layer")?,
        need("dwell_s")?,
    );
    let (cp, cdrop) = (col("pace"), col("drop"));
    let mut out: Vec<PathRow> = Vec::new();
    for (k, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f = fields(line);
        let bad = |what: String| at_line(file, k + 1, what);
        let number = |c: usize, name: &str| -> Result<f64> {
            f.get(c)
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(format!("{name} = {:?}; expected a number", f.get(c))))
        };
        let index = number(ci, "i")?;
        if index != out.len() as f64 {
            return Err(bad(format!(
                "i = {index}; expected {} (the points in order, from 0)",
                out.len()
            )));
        }
        let layer = number(cl, "layer")?;
        if layer < 0.0 || layer.fract() != 0.0 || layer > 1e7 {
            return Err(bad(format!("layer = {layer}; expected a whole number ≥ 0")));
        }
        let dwell_s = number(cd, "dwell_s")?;
        if !(0.0..=1e6).contains(&dwell_s) {
            return Err(bad(format!("dwell_s = {dwell_s}; expected 0 to 1e6 s")));
        }
        let pace = match cp {
            Some(c) => number(c, "pace")?,
            None => 1.0,
        };
        if !(pace > 0.0 && pace <= 100.0) {
            return Err(bad(format!("pace = {pace}; expected in (0, 100]")));
        }
        let drop = match cdrop {
            Some(c) => number(c, "drop")?,
            None => 0.0,
        };
        let drop = match drop {
            0.0 => 0,
            1.0 => 1,
            2.0 if out.last().is_some_and(|r| r.drop > 0) => 2,
            _ => {
                return Err(bad(format!(
                    "drop = {drop}; expected 0, 1 (a drop strikes) or 2 (after a 1 or a 2)"
                )));
            }
        };
        out.push(PathRow {
            position_mm: [number(cx, "x")?, number(cy, "y")?, number(cz, "z")?],
            layer: layer as usize,
            dwell_s,
            pace,
            drop,
        });
    }
    if out.is_empty() {
        return Err(Error::input(format!(
            "{file}: no rows; expected a path.csv with a row per path point"
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "i,x,y,z,layer,t_s,dwell_s,pace,drop\n";

    #[test]
    fn a_dwell_runs_path_reads_back() {
        let text = format!(
            "{HEAD}0,1,2,3,0,0.5,0.000,1.0,0\n1,1,2,4,1,9,7.5,1.25,1\n2,1,2,5,1,10,0,1.25,2\n"
        );
        let r = rows(&text, "path.csv").unwrap();
        assert_eq!(r.len(), 3);
        assert_eq!(r[1].dwell_s, 7.5);
        assert_eq!((r[1].pace, r[1].drop, r[2].drop), (1.25, 1, 2));
        // A plan run's path.csv has neither pace nor drop.
        let plan = "i,x,y,z,layer,dwell_s\n0,0,0,1,0,0\n";
        assert_eq!(rows(plan, "p.csv").unwrap()[0].pace, 1.0);
    }

    #[test]
    fn bad_rows_are_named_by_line() {
        let bad = |t: &str| rows(&format!("{HEAD}{t}"), "path.csv").unwrap_err().message;
        assert!(bad("0,1,2,3,0,0.5,-1,1,0\n").contains("line 2: dwell_s = -1"));
        assert!(bad("1,1,2,3,0,0.5,0,1,0\n").contains("i = 1; expected 0"));
        assert!(bad("0,1,2,3,0,0.5,0,1,2\n").contains("drop = 2"));
        assert!(bad("0,1,x,3,0,0.5,0,1,0\n").contains("y = "));
        let e = rows("a,b\n1,2\n", "p.csv").unwrap_err().message;
        assert!(e.contains("no column `i`"), "{e}");
    }
}
