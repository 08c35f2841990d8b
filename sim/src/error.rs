//! The one error type of the command line: bad input (exit 2) or a failure of ours (exit 1).

use std::fmt;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The user's input is wrong: a file, a field or a value. Exit code 2.
    Input,
    /// Something failed that the input did not cause (disk full, a numerical breakdown). Exit 1.
    Failure,
    /// The run was asked to stop (`thermal::run::request_stop`: Python's Ctrl-C). Exit 130, as
    /// a shell reports a command ended by SIGINT.
    Stopped,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    pub kind: ErrorKind,
    /// One line: names the file, field or line, the value and what was expected.
    pub message: String,
}

impl Error {
    pub fn input(message: impl Into<String>) -> Self {
        Self {
            kind: ErrorKind::Input,
            message: one_line(message.into()),
        }
    }
    pub fn failure(message: impl Into<String>) -> Self {
        Self {
            kind: ErrorKind::Failure,
            message: one_line(message.into()),
        }
    }
    pub fn exit_code(&self) -> i32 {
        match self.kind {
            ErrorKind::Input => 2,
            ErrorKind::Failure => 1,
            ErrorKind::Stopped => 130,
        }
    }
    /// Prefix the message with where it happened (a file, a command).
    pub fn context(mut self, what: impl fmt::Display) -> Self {
        self.message = format!("{what}: {}", self.message);
        self
    }
}

fn one_line(s: String) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

/// A schedule or plate the heat model cannot take is the user's input (exit 2); a numerical
/// failure, with its time, place and value, is ours (exit 1).
impl From<thermal::ThermalError> for Error {
    fn from(e: thermal::ThermalError) -> Self {
        let mut message = format!("thermal: {e}");
        if let thermal::ThermalError::OutsidePlate { .. } = e {
            // The one key that moves the plate's edge: the user's `plate_mm` (a left-out one is
            // fitted to the part and holds it).
            message.push_str(
                "; expected a plate that holds the part: [thermal] plate_mm larger, or left out \
                 to fit the plate to the part",
            );
        }
        if let thermal::ThermalError::Stopped { .. } = e {
            return Error {
                kind: ErrorKind::Stopped,
                message,
            };
        }
        if e.is_input() {
            Error::input(message)
        } else {
            Error::failure(message)
        }
    }
}

impl From<crate::pipeline::Error> for Error {
    fn from(e: crate::pipeline::Error) -> Self {
        match e {
            crate::pipeline::Error::Plan(_)
            | crate::pipeline::Error::Unseated(_)
            | crate::pipeline::Error::Measured(_)
            | crate::pipeline::Error::Invalid(_) => Error::input(e.to_string()),
            crate::pipeline::Error::Thermal(t) => t.into(),
            crate::pipeline::Error::Lost(_) => Error::failure(e.to_string()),
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;
    use thermal::ThermalError;

    #[test]
    fn numerical_failures_exit_1_and_bad_schedules_exit_2() {
        let nan = ThermalError::NonFinite {
            time_s: 12.5,
            position_mm: [1.0, 2.0, 3.0],
            what: "temperature (K)",
            value: f64::NAN,
        };
        let e = Error::from(nan);
        assert_eq!(e.exit_code(), 1);
        assert!(e.message.contains("t = 12.500 s") && e.message.contains("(1.0, 2.0, 3.0) mm"));
        let outside = ThermalError::OutsidePlate {
            deposit: 3,
            x_mm: 400.0,
            y_mm: 0.0,
        };
        let e = Error::from(outside);
        assert_eq!(e.exit_code(), 2);
        assert!(e.message.contains("plate_mm"), "{}", e.message);
    }
}
