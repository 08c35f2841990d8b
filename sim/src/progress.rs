//! Progress on stderr for steps that take more than a moment (hidden when stderr is not a
//! terminal, so logs and tests stay clean).

use indicatif::{ProgressBar, ProgressStyle};
use std::sync::{Arc, RwLock};
use std::time::Duration;

/// Who hears of progress besides the terminal: told `(stage, done, total)` as a bar moves and
/// `(stage, 0, 0)` as a spinner's stage starts. One for the process (the Python package's
/// progress callback); it must be quick, as it is told from the engine's own threads.
pub type Observer = dyn Fn(&str, u64, u64) + Send + Sync;

static OBSERVER: RwLock<Option<Arc<Observer>>> = RwLock::new(None);

/// Tell `observer` of progress from now on (`None`: nobody).
pub fn observe(observer: Option<Arc<Observer>>) {
    if let Ok(mut o) = OBSERVER.write() {
        *o = observer;
    }
}

fn tell(stage: &str, done: u64, total: u64) {
    let observer = OBSERVER.read().ok().and_then(|o| o.clone());
    if let Some(o) = observer {
        o(stage, done, total);
    }
}

/// A spinner with a message for one stage; cleared when dropped.
pub struct Stage(ProgressBar);

impl Stage {
    pub fn start(message: &str) -> Stage {
        let bar = ProgressBar::new_spinner();
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg} {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        bar.set_message(message.to_string());
        bar.enable_steady_tick(Duration::from_millis(120));
        tell(message, 0, 0);
        Stage(bar)
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

/// A bar with an ETA for a stage that counts its work (deposits laid): drawn on stderr when it
/// is a terminal, nothing on a pipe (indicatif hides it there); cleared when dropped.
pub struct Bar(ProgressBar, String);

impl Bar {
    pub fn start(message: &str, total: u64) -> Bar {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}, ETA {eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        tell(message, 0, total);
        Bar(bar, message.to_string())
    }

    /// `done` of `total` done.
    pub fn set(&self, done: usize, total: usize) {
        self.0.set_length(total as u64);
        self.0.set_position(done as u64);
        tell(&self.1, done as u64, total as u64);
    }
}

impl Drop for Bar {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

/// An engine call's progress on the terminal: a spinner per stage, turned into a bar with an
/// ETA once the stage lays deposits.
#[derive(Default)]
pub struct Terminal {
    what: String,
    stage: Option<Stage>,
    bar: Option<Bar>,
}

impl crate::pipeline::Report for Terminal {
    fn stage(&mut self, what: &str) {
        (self.bar, self.stage) = (None, None);
        self.what = what.to_string();
        self.stage = Some(Stage::start(what));
    }

    fn laid(&mut self, done: usize, total: usize) {
        if self.bar.is_none() {
            self.stage = None;
            self.bar = Some(Bar::start(&self.what, total as u64));
        }
        if let Some(b) = &self.bar {
            b.set(done, total);
        }
    }
}
