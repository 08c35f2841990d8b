//! `waamtwin._native`: the commands of `waamtwin` for the Python package (`waamtwin/`
//! beside this crate holds the Python side: scenarios as paths, strings or dicts, results as
//! numpy tables).
//!
//! A command runs exactly as on the command line (`sim::execute` of the same arguments, so the
//! same checks, messages and files), on a thread of its own: the calling thread lets go of
//! the GIL and, ten times a second, takes it back to pass progress to the caller's callback
//! and to look for Ctrl-C (Python hears of a signal only when some thread holding the GIL
//! asks). On Ctrl-C the heat runs are asked to stop (`thermal::run::request_stop`), the
//! command returns at its next deposit, and `KeyboardInterrupt` is raised; `follow` instead
//! ends as its command does on Ctrl-C, with every output written.

use numpy::PyArray1;
use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::sync::{Arc, Mutex, TryLockError};
use std::time::Duration;

create_exception!(
    _native,
    InputError,
    PyValueError,
    "Bad input: a scenario, a file, a field or a value (the command's exit code 2)."
);
create_exception!(
    _native,
    SimulationError,
    PyRuntimeError,
    "A failure the input did not cause: a numerical breakdown, a full disk (exit code 1)."
);

/// How often the waiting thread takes the GIL back to report progress and look for Ctrl-C.
const POLL: Duration = Duration::from_millis(100);

/// Run `waamtwin ARGV…` and return what the command prints. `progress(stage, done, total)` is
/// called with the latest progress at most ten times a second.
#[pyfunction]
#[pyo3(signature = (argv, progress = None))]
fn run(py: Python<'_>, argv: Vec<String>, progress: Option<Py<PyAny>>) -> PyResult<String> {
    let args = std::iter::once("waamtwin".to_string()).chain(argv);
    let cli = <sim::cli::Cli as clap::Parser>::try_parse_from(args)
        .map_err(|e| InputError::new_err(e.render().to_string().trim().to_string()))?;
    let follow = matches!(cli.command, sim::cli::Command::Follow { .. });
    // One run at a time in the process: the progress observer and the stop request are the
    // process's, and each run uses every core already (rayon). A second caller waits here
    // with the GIL let go, and Ctrl-C ends its wait.
    static ONE_RUN: Mutex<()> = Mutex::new(());
    let _one = loop {
        match ONE_RUN.try_lock() {
            Ok(g) => break g,
            Err(TryLockError::Poisoned(p)) => break p.into_inner(),
            Err(TryLockError::WouldBlock) => {
                py.detach(|| std::thread::sleep(POLL));
                py.check_signals()?;
            }
        }
    };
    let latest: Arc<Mutex<Option<(String, u64, u64)>>> = Arc::default();
    let told = latest.clone();
    sim::progress::observe(Some(Arc::new(move |stage: &str, done, total| {
        if let Ok(mut l) = told.lock() {
            *l = Some((stage.to_string(), done, total));
        }
    })));
    thermal::run::clear_stop();
    sim::commands::follow::clear_interrupt();
    let (tx, rx) = channel();
    // Behind a lock only to be Sync for `detach`: this thread alone receives.
    let rx = Mutex::new(rx);
    let worker = std::thread::spawn(move || {
        // On one of rayon's workers, as `waamtwin`'s main runs it (docs/PERFORMANCE.md).
        let _ = tx.send(rayon::scope(|_| sim::execute(cli)));
    });
    let mut interrupted: Option<PyErr> = None;
    let outcome = loop {
        let got = py.detach(|| match rx.lock() {
            Ok(rx) => rx.recv_timeout(POLL),
            Err(_) => Err(RecvTimeoutError::Disconnected),
        });
        match got {
            Ok(r) => break Some(r),
            Err(RecvTimeoutError::Disconnected) => break None,
            Err(RecvTimeoutError::Timeout) => {}
        }
        let asked = py.check_signals().err().or_else(|| {
            let now = latest.lock().ok().and_then(|mut l| l.take());
            let cb = progress.as_ref()?;
            let (stage, done, total) = now?;
            cb.call1(py, (stage, done, total)).err()
        });
        if let Some(e) = asked {
            // The first Ctrl-C ends a follow as its command's does; a second, or any other
            // command's, stops the heat runs.
            match (follow, interrupted.is_some()) {
                (true, false) => sim::commands::follow::interrupt(),
                _ => thermal::run::request_stop(),
            }
            interrupted.get_or_insert(e);
        }
    };
    let _ = py.detach(|| worker.join());
    sim::progress::observe(None);
    thermal::run::clear_stop();
    match (outcome, interrupted) {
        (Some(Ok(line)), None) => Ok(line),
        // A follow that Ctrl-C ended has written its outputs: its result stands.
        (Some(Ok(line)), Some(_)) if follow => Ok(line),
        (_, Some(e)) => Err(e),
        (Some(Err(e)), None) => Err(match e.kind {
            sim::error::ErrorKind::Input => InputError::new_err(e.message),
            sim::error::ErrorKind::Stopped => PyKeyboardInterrupt::new_err(e.message),
            sim::error::ErrorKind::Failure => SimulationError::new_err(e.message),
        }),
        (None, None) => Err(SimulationError::new_err(
            "the command's thread ended without a result (a panic: a bug, please report it)",
        )),
    }
}

/// A scenario given as JSON (the Python dict of its sections), as TOML text.
#[pyfunction]
fn toml_from_json(json: &str) -> PyResult<String> {
    let value: toml::Value =
        serde_json::from_str(json).map_err(|e| InputError::new_err(format!("scenario: {e}")))?;
    toml::to_string(&value).map_err(|e| InputError::new_err(format!("scenario: {e}")))
}

/// A CSV file the commands write, as a dict of its columns: numbers as float64 arrays (an
/// empty field is NaN), a column with any other text as a list of str.
#[pyfunction]
fn read_table<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let text = std::fs::read_to_string(&path)
        .map_err(|e| InputError::new_err(format!("{}: {e}", path.display())))?;
    let columns = py.detach(|| columns(&text));
    let dict = PyDict::new(py);
    for (name, column) in columns {
        match column {
            Column::Numbers(v) => dict.set_item(name, PyArray1::from_vec(py, v))?,
            Column::Text(v) => dict.set_item(name, PyList::new(py, v)?)?,
        }
    }
    Ok(dict)
}

enum Column {
    Numbers(Vec<f64>),
    Text(Vec<String>),
}

/// The columns of CSV text, in the header's order; a short row's missing fields are empty.
fn columns(text: &str) -> Vec<(String, Column)> {
    let mut lines = text.lines();
    let header = lines.next().map(fields).unwrap_or_default();
    let mut cells: Vec<Vec<String>> = vec![Vec::new(); header.len()];
    for line in lines.filter(|l| !l.is_empty()) {
        let mut row = fields(line).into_iter();
        for c in cells.iter_mut() {
            c.push(row.next().unwrap_or_default());
        }
    }
    header
        .into_iter()
        .zip(cells)
        .map(|(name, c)| {
            let numbers: Option<Vec<f64>> = c
                .iter()
                .map(|s| match s.trim() {
                    "" => Some(f64::NAN),
                    t => t.parse().ok(),
                })
                .collect();
            (name, numbers.map_or(Column::Text(c), Column::Numbers))
        })
        .collect()
}

/// One CSV line's fields; a field in double quotes may hold commas and doubled quotes.
fn fields(line: &str) -> Vec<String> {
    let (mut out, mut field, mut quoted) = (Vec::new(), String::new(), false);
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                field.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut field)),
            (c, _) => field.push(c),
        }
    }
    out.push(field);
    out
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(toml_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(read_table, m)?)?;
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add("SimulationError", m.py().get_type::<SimulationError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
