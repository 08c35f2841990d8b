//! A step's chunks shared by threads that keep to their own end of the active set.
//!
//! A step of the voxel model is a few hundred microseconds of work over the active set, cut
//! into chunks, and a run takes tens of thousands of them back to back. Handed to rayon one
//! chunk a task, a chunk went to whichever thread was free, a different one from step to step;
//! two threads reached 1.4–1.7× one thread's speed on a machine that runs two one-thread runs
//! side by side at twice the throughput of one. Here the thread that drives the run takes chunks
//! from the front of the set and the helpers from the back, until they meet: each core steps
//! about the same voxels every step, and a thread done early still takes the other's next
//! chunk. Measured on the issue-19 cylinder: two threads faster than rayon's in six rounds of
//! six, 1.76× one thread where rayon got 1.58× (medians); the helpers' sleeps between steps
//! taken out alone, with the chunks still handed out from one end, gained in some rounds and
//! lost in others (docs/PERFORMANCE.md, "Two cores", "Each core its own end").
//!
//! The helpers are threads of their own, started at the first step that is shared out and kept
//! for the process; between steps they spin for at most `SPIN`, then park. One run steps on them
//! at a time: a step that finds them busy (runs of an ensemble or a study side by side) goes to
//! rayon, as before. What each chunk returns is kept by its index, so the numbers are the same
//! to the bit on any number of threads, and on either path.

use rayon::prelude::*;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, TryLockError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long a helper waits for the next step before it parks: longer than the gap between two
/// steps of a deposit (some 5 µs measured), shorter than the work between deposits.
const SPIN: Duration = Duration::from_micros(200);

/// A parked helper looks again this often, whether or not it was woken.
const NAP: Duration = Duration::from_millis(100);

/// The process's helpers, idle or stepping one run's chunks.
static CREW: Mutex<Option<Crew>> = Mutex::new(None);

/// Run `job` on chunks 0..n on this thread and the pool's others, each chunk once; returns when
/// all are done. A panic in a chunk reaches the caller once every chunk claimed is done.
pub(super) fn step(n: usize, job: &(dyn Fn(usize) + Sync)) {
    on_crew(n, job, false);
}

/// `step`, where the helpers are busy waiting for them if `wait`, else on rayon.
fn on_crew(n: usize, job: &(dyn Fn(usize) + Sync), wait: bool) {
    let threads = rayon::current_num_threads();
    if threads < 2 || n < 2 {
        return (0..n).for_each(job);
    }
    let mut crew = match CREW.try_lock() {
        Ok(crew) => crew,
        // A step panicked on the team: its chunks were all done before the panic went on.
        Err(TryLockError::Poisoned(p)) => p.into_inner(),
        Err(TryLockError::WouldBlock) if wait => lock(&CREW),
        Err(TryLockError::WouldBlock) => return (0..n).into_par_iter().for_each(job),
    };
    if crew.as_ref().is_none_or(|c| c.helpers.len() + 1 != threads) {
        *crew = Crew::start(threads - 1);
    }
    match crew.as_mut() {
        Some(c) => c.step(n, job),
        None => (0..n).into_par_iter().for_each(job),
    }
}

/// A step's job as the helpers see it: a pointer to the closure, its lifetime erased.
/// Called only through a claimed chunk of its step, while `Crew::step` waits for that chunk.
#[derive(Clone, Copy)]
struct Job(*const (dyn Fn(usize) + Sync + 'static));

// SAFETY: the closure behind the pointer is `Sync`; `Job` says when it is called.
unsafe impl Send for Job {}

struct Shared {
    /// The step's number (high 32 bits), the front (16 bits) and back (16 bits) of the chunks
    /// not yet claimed: chunks front..back are left.
    left: AtomicU64,
    /// Chunks of the current step done.
    done: AtomicUsize,
    /// The current step's job, with its number.
    job: Mutex<Option<(u32, Job)>>,
    /// Per helper: it is parked, or about to park, and must be woken.
    parked: Vec<AtomicBool>,
    quit: AtomicBool,
    /// A chunk panicked on a helper.
    failed: AtomicBool,
}

struct Crew {
    shared: Arc<Shared>,
    helpers: Vec<JoinHandle<()>>,
    step: u32,
}

/// The most chunks a step may have: the front and back are 16 bits each (268 M voxels).
const MAX_CHUNKS: usize = 0xffff;

impl Crew {
    /// `count` helpers, or none where the system will not start a thread.
    fn start(count: usize) -> Option<Crew> {
        let shared = Arc::new(Shared {
            left: AtomicU64::new(0),
            done: AtomicUsize::new(0),
            job: Mutex::new(None),
            parked: (0..count).map(|_| AtomicBool::new(false)).collect(),
            quit: AtomicBool::new(false),
            failed: AtomicBool::new(false),
        });
        let mut helpers = Vec::new();
        for i in 0..count {
            let s = shared.clone();
            let spawned = std::thread::Builder::new()
                .name(format!("voxel-step-{i}"))
                .spawn(move || help(&s, i));
            match spawned {
                Ok(h) => helpers.push(h),
                Err(_) => break,
            }
        }
        let crew = Crew {
            shared,
            helpers,
            step: 0,
        };
        // Short of helpers, the crew is let go (dropped: the ones started leave).
        (crew.helpers.len() == count).then_some(crew)
    }

    fn step(&mut self, n: usize, job: &(dyn Fn(usize) + Sync)) {
        if n > MAX_CHUNKS {
            return (0..n).into_par_iter().for_each(job);
        }
        let shared = &*self.shared;
        self.step = self.step.wrapping_add(1);
        let step = self.step;
        let erased: *const (dyn Fn(usize) + Sync + '_) = job;
        // SAFETY: only the lifetime changes. The helpers call it through `work` alone, after
        // claiming a chunk of this step, and this function does not return (nor unwind) before
        // every chunk of it is done; no chunk of it can be claimed after.
        let erased = Job(unsafe {
            std::mem::transmute::<
                *const (dyn Fn(usize) + Sync + '_),
                *const (dyn Fn(usize) + Sync + 'static),
            >(erased)
        });
        *lock(&shared.job) = Some((step, erased));
        shared.done.store(0, Ordering::Relaxed);
        shared.failed.store(false, Ordering::Relaxed);
        shared
            .left
            .store(((step as u64) << 32) | n as u64, Ordering::SeqCst);
        for (h, parked) in self.helpers.iter().zip(&shared.parked) {
            if parked.swap(false, Ordering::SeqCst) {
                h.thread().unpark();
            }
        }
        let mine =
            std::panic::catch_unwind(AssertUnwindSafe(|| work(shared, step, erased, End::Front)));
        let start = Instant::now();
        while shared.done.load(Ordering::Acquire) < n {
            match start.elapsed() < SPIN {
                true => std::hint::spin_loop(),
                false => std::thread::yield_now(),
            }
        }
        *lock(&shared.job) = None;
        if let Err(panic) = mine {
            std::panic::resume_unwind(panic);
        }
        if shared.failed.load(Ordering::Acquire) {
            panic!("a chunk of a voxel step panicked on a helper thread");
        }
    }
}

impl Drop for Crew {
    fn drop(&mut self) {
        self.shared.quit.store(true, Ordering::SeqCst);
        for h in self.helpers.drain(..) {
            h.thread().unpark();
            let _ = h.join();
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Which end of the chunks left a thread takes from.
#[derive(Clone, Copy)]
enum End {
    Front,
    Back,
}

/// The step, front and back packed in `Shared::left`.
fn unpack(left: u64) -> (u32, u64, u64) {
    ((left >> 32) as u32, (left >> 16) & 0xffff, left & 0xffff)
}

/// Counts a claimed chunk done when dropped, so that the driver's wait ends where the chunk
/// panicked too.
struct Done<'a>(&'a Shared);

impl Drop for Done<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.failed.store(true, Ordering::Release);
        }
        self.0.done.fetch_add(1, Ordering::AcqRel);
    }
}

/// Claim chunks of `step` from one end and run them until none is left.
fn work(shared: &Shared, step: u32, job: Job, end: End) {
    let mut left = shared.left.load(Ordering::Acquire);
    loop {
        let (s, front, back) = unpack(left);
        if s != step || front >= back {
            return;
        }
        let (k, claimed) = match end {
            End::Front => (front, left + (1 << 16)),
            End::Back => (back - 1, left - 1),
        };
        match shared
            .left
            .compare_exchange_weak(left, claimed, Ordering::AcqRel, Ordering::Acquire)
        {
            Ok(_) => {
                let done = Done(shared);
                // SAFETY: chunk k of `step` is claimed and not done, so `Crew::step` is
                // waiting for it and the closure is alive (`Job`).
                unsafe { (*job.0)(k as usize) };
                drop(done);
                left = shared.left.load(Ordering::Acquire);
            }
            Err(now) => left = now,
        }
    }
}

/// A helper's life: wait for a step (spinning, then parked), take chunks from the back, again.
fn help(shared: &Shared, me: usize) {
    let mut seen = 0u32;
    loop {
        let step = match next_step(shared, me, seen) {
            Some(s) => s,
            None => return,
        };
        seen = step;
        let job = *lock(&shared.job);
        if let Some((s, job)) = job
            && s == step
        {
            // A chunk's panic is the driver's to report (`Done`); the helper carries on.
            let _ =
                std::panic::catch_unwind(AssertUnwindSafe(|| work(shared, step, job, End::Back)));
        }
    }
}

/// Wait for a step after `seen`; None once the crew is let go.
fn next_step(shared: &Shared, me: usize, seen: u32) -> Option<u32> {
    let start = Instant::now();
    loop {
        if shared.quit.load(Ordering::Acquire) {
            return None;
        }
        let (step, _, _) = unpack(shared.left.load(Ordering::Acquire));
        if step != seen {
            return Some(step);
        }
        if start.elapsed() < SPIN {
            std::hint::spin_loop();
            continue;
        }
        shared.parked[me].store(true, Ordering::SeqCst);
        // Looked at again after saying so: a step published before the flag was seen would
        // not wake this helper.
        let (step, _, _) = unpack(shared.left.load(Ordering::SeqCst));
        if step == seen && !shared.quit.load(Ordering::SeqCst) {
            std::thread::park_timeout(NAP);
        }
        shared.parked[me].store(false, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicU32;
    use std::sync::mpsc;

    /// `f` on a pool of `threads`, failed rather than hung where it does not finish in a
    /// minute (a chunk never done would keep the driver waiting).
    fn on_threads(threads: usize, f: impl FnOnce() + Send + 'static) {
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let r = std::panic::catch_unwind(AssertUnwindSafe(|| pool.install(f)));
            let _ = tx.send(r.is_ok());
        });
        match rx.recv_timeout(Duration::from_secs(60)) {
            Ok(ok) => assert!(ok, "{threads} threads: the test's body panicked"),
            Err(_) => panic!("{threads} threads: not done in 60 s"),
        }
    }

    /// A chunk's work: long enough for the helpers to claim some.
    fn busy() {
        let start = Instant::now();
        while start.elapsed() < Duration::from_micros(20) {
            std::hint::spin_loop();
        }
    }

    /// Every chunk runs once a step, on one to four threads, over many steps back to back and
    /// after a pause long enough for the helpers to park; on more than one thread, helpers take
    /// some of them.
    #[test]
    fn every_chunk_runs_once_a_step() {
        for threads in 1..=4 {
            on_threads(threads, move || {
                let helped = AtomicU32::new(0);
                let sizes = [0usize, 1, 2, 3, 8, 77];
                for (round, n) in sizes.into_iter().cycle().take(120).enumerate() {
                    let counts: Vec<AtomicU32> = (0..n).map(|_| AtomicU32::new(0)).collect();
                    let chunk = |k: usize| {
                        busy();
                        counts[k].fetch_add(1, Ordering::Relaxed);
                        let name = std::thread::current().name().map(str::to_owned);
                        if name.is_some_and(|n| n.starts_with("voxel-step-")) {
                            helped.fetch_add(1, Ordering::Relaxed);
                        }
                    };
                    // Waiting for the helpers where another test steps on them.
                    on_crew(n, &chunk, true);
                    assert!(
                        counts.iter().all(|c| c.load(Ordering::Relaxed) == 1),
                        "{n} chunks"
                    );
                    if round == 60 {
                        std::thread::sleep(SPIN * 5);
                    }
                }
                let helped = helped.load(Ordering::Relaxed);
                assert_eq!(helped > 0, threads > 1, "{helped} chunks on the helpers");
            });
        }
    }

    /// A chunk's panic reaches the caller, from the driver's end or a helper's, and the team
    /// steps on after it.
    #[test]
    fn a_chunk_that_panics_reaches_the_caller() {
        on_threads(2, || {
            for bad in [0, 63] {
                let r = std::panic::catch_unwind(|| {
                    let chunk = |k: usize| {
                        busy();
                        if k == bad {
                            panic!("chunk {k}, as the test asks");
                        }
                    };
                    on_crew(64, &chunk, true)
                });
                assert!(r.is_err(), "chunk {bad}");
                let count = AtomicU32::new(0);
                let chunk = |_: usize| {
                    busy();
                    count.fetch_add(1, Ordering::Relaxed);
                };
                on_crew(64, &chunk, true);
                assert_eq!(count.load(Ordering::Relaxed), 64);
            }
        });
    }
}
