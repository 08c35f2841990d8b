//! Checkpoints: the state of a long computation kept as it goes, so that a killed run goes on
//! from where it was last kept and ends with the outputs one uninterrupted run gives.
//!
//! The engine names the stages of its work (`before`, `search`, …) and hands their state over
//! as bytes; where and how often they are kept is the [`Store`]'s business (the commands keep
//! them as files beside the outputs, `sim::commands::checkpoint`). A stage's state is either
//! work in progress (a heat run part-way, the dwell search between two revolutions) or the
//! stage's result once it is done; a run that resumes takes the result where there is one,
//! else goes on from the work in progress, else starts the stage.
//!
//! Identity: a heat run goes on from a kept state exactly as it would have gone on from its
//! copy in memory (cloning a run is the dwell planner's checkpoint already); the bytes keep
//! every number to the bit (postcard: floats as their IEEE bytes), so the outputs are the
//! same.

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::time::Instant;

/// Where a run's states are kept.
pub trait Store {
    /// Whether the interval since a state was last kept has passed.
    fn due(&self) -> bool;
    /// The state kept under `stage` by an earlier run of the same work.
    fn load(&mut self, stage: &str) -> Option<Vec<u8>>;
    /// Keep `bytes` under `stage`, replacing what was kept there.
    fn save(&mut self, stage: &str, bytes: &[u8]);
    /// Forget `stage` (its work is done and kept under another name).
    fn remove(&mut self, stage: &str);
    /// The state kept under `stage` did not read as what the stage keeps (`why`, the
    /// decoder's words): the stage starts again, to the same outputs, so only this tells a
    /// resume from a restart. The store checked the version and the work the state was kept
    /// for, so this is a bug; a store says so where a person or a test can see it.
    fn unreadable(&mut self, stage: &str, why: &str);
}

/// A run's checkpoints: to a [`Store`], or off. Every state is kept with the wall-clock
/// seconds its stage had taken when it was kept, so that a stage that resumed reports the time
/// it took in all (less what was lost since its last checkpoint), not only its last part.
pub struct Checkpoints<'a> {
    store: Option<&'a mut dyn Store>,
    /// When this process started on the stage, and the seconds spent on it before.
    started: Instant,
    before_s: f64,
}

impl<'a> Checkpoints<'a> {
    /// Nothing kept, nothing resumed.
    pub fn off() -> Checkpoints<'a> {
        Checkpoints {
            store: None,
            started: Instant::now(),
            before_s: 0.0,
        }
    }

    pub fn to(store: &'a mut dyn Store) -> Checkpoints<'a> {
        Checkpoints {
            store: Some(store),
            ..Checkpoints::off()
        }
    }

    /// The same store for a stage of the work, its clock started now.
    fn for_stage(&mut self) -> Checkpoints<'_> {
        Checkpoints {
            store: self.store.as_mut().map(|s| &mut **s as &mut dyn Store),
            started: Instant::now(),
            before_s: 0.0,
        }
    }

    /// Wall-clock seconds spent on the stage, by this process and those before it.
    pub fn spent_s(&self) -> f64 {
        self.before_s + self.started.elapsed().as_secs_f64()
    }

    /// The state kept under `stage`, if there is one and it reads as a `T`. The store checked
    /// that it was written by this version for this work; one that still does not read (which
    /// that check makes a bug) is not used, the store is told ([`Store::unreadable`]), and the
    /// stage starts again.
    pub fn load<T: DeserializeOwned>(&mut self, stage: &str) -> Option<T> {
        let store = self.store.as_mut()?;
        let bytes = store.load(stage)?;
        match postcard::from_bytes::<(f64, T)>(&bytes) {
            Ok((spent_s, state)) => {
                self.before_s = spent_s;
                self.started = Instant::now();
                Some(state)
            }
            Err(e) => {
                store.unreadable(stage, &e.to_string());
                None
            }
        }
    }

    /// Keep `state` under `stage` now.
    pub fn save<T: Serialize + ?Sized>(&mut self, stage: &str, state: &T) {
        let spent_s = self.spent_s();
        if let Some(store) = self.store.as_mut() {
            // Serialising plain data fails only where a type cannot be written (a map with
            // keys postcard cannot take): none of ours. The bytes are counted first and the
            // vector made that long: grown by doubling it held up to twice a state's bytes, and
            // a `follow`'s state is every member's field (docs/PERFORMANCE.md "`follow`'s
            // memory").
            let kept = (spent_s, state);
            let bytes = postcard::experimental::serialized_size(&kept)
                .and_then(|n| postcard::to_extend(&kept, Vec::with_capacity(n)));
            if let Ok(bytes) = bytes {
                store.save(stage, &bytes);
            }
        }
    }

    /// Whether a state handed over now would be kept ([`Checkpoints::save_if_due`]).
    pub fn due(&self) -> bool {
        self.store.as_ref().is_some_and(|s| s.due())
    }

    /// Keep `state` under `stage` if the interval has passed; `state` is only made then.
    pub fn save_if_due<T: Serialize>(&mut self, stage: &str, state: impl FnOnce() -> T) {
        if self.due() {
            self.save(stage, &state());
        }
    }

    pub fn remove(&mut self, stage: &str) {
        if let Some(store) = self.store.as_mut() {
            store.remove(stage);
        }
    }

    /// Stage `stage`'s result and the wall-clock seconds it took, where an earlier run kept it.
    pub fn done<T: DeserializeOwned>(&mut self, stage: &str) -> Option<(T, f64)> {
        let mut ck = self.for_stage();
        let done = ck.load::<T>(stage)?;
        Some((done, ck.before_s))
    }

    /// Keep `result` as stage `stage`'s, made elsewhere (on another thread) in `spent_s`
    /// wall-clock seconds.
    pub fn keep_done<T: Serialize>(&mut self, stage: &str, result: &T, spent_s: f64) {
        let mut ck = self.for_stage();
        ck.before_s = spent_s;
        ck.save(stage, result);
    }

    /// Stage `stage`'s result and the wall-clock seconds it took: kept by an earlier run, or
    /// made by `work` (which may keep its work in progress under `stage.run`) and kept.
    pub fn stage<T, E>(
        &mut self,
        stage: &str,
        work: impl FnOnce(&mut Checkpoints<'_>, &str) -> Result<T, E>,
    ) -> Result<(T, f64), E>
    where
        T: Serialize + DeserializeOwned,
    {
        let mut ck = self.for_stage();
        if let Some(done) = ck.load::<T>(stage) {
            return Ok((done, ck.before_s));
        }
        let progress = format!("{stage}.run");
        let result = work(&mut ck, &progress)?;
        ck.save(stage, &result);
        ck.remove(&progress);
        Ok((result, ck.spent_s()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// A store in memory, always due.
    #[derive(Default)]
    struct Memory {
        kept: BTreeMap<String, Vec<u8>>,
        saves: usize,
        unreadable: Vec<String>,
    }

    impl Store for Memory {
        fn due(&self) -> bool {
            true
        }
        fn load(&mut self, stage: &str) -> Option<Vec<u8>> {
            self.kept.get(stage).cloned()
        }
        fn save(&mut self, stage: &str, bytes: &[u8]) {
            self.saves += 1;
            self.kept.insert(stage.into(), bytes.to_vec());
        }
        fn remove(&mut self, stage: &str) {
            self.kept.remove(stage);
        }
        fn unreadable(&mut self, stage: &str, _why: &str) {
            self.unreadable.push(stage.into());
        }
    }

    /// A state that does not read as the stage's is not used, and the store hears of it: the
    /// stage's work is done again.
    #[test]
    fn a_state_that_does_not_read_is_told_and_its_stage_starts_again() {
        let mut m = Memory::default();
        let mut ck = Checkpoints::to(&mut m);
        ck.save("before", &7u8);
        let (made, _) = ck
            .stage("before", |_, _| Ok::<_, ()>(vec![1.0f64, 2.0]))
            .unwrap();
        assert_eq!(made, vec![1.0, 2.0]);
        assert_eq!(m.unreadable, vec!["before".to_string()]);
        assert!(m.kept.contains_key("before"));
    }

    #[test]
    fn a_stage_done_is_taken_and_its_work_in_progress_dropped() {
        let mut m = Memory::default();
        let mut ck = Checkpoints::to(&mut m);
        let work = |ck: &mut Checkpoints<'_>, progress: &str| {
            ck.save(progress, &1.5f64);
            Ok::<_, ()>(vec![f64::NAN, -0.0, 1e-310])
        };
        let (first, _) = ck.stage("before", work).unwrap();
        // The second time the work is not done again.
        let (again, _) = ck
            .stage::<Vec<f64>, ()>("before", |_, _| panic!("done already"))
            .unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&first), bits(&again));
        assert!(m.kept.contains_key("before") && !m.kept.contains_key("before.run"));
        assert_eq!(m.saves, 2);
    }

    /// A stage made on another thread is kept as [`Checkpoints::stage`] keeps one: a resumed
    /// run takes it, with the seconds it took, and `stage` does not make it again.
    #[test]
    fn a_stage_made_elsewhere_is_kept_with_its_time() {
        let mut m = Memory::default();
        let mut ck = Checkpoints::to(&mut m);
        assert!(ck.done::<u32>("revolution_dwell").is_none());
        ck.keep_done("revolution_dwell", &7u32, 42.0);
        let (kept, spent_s) = ck.done::<u32>("revolution_dwell").unwrap();
        assert_eq!(kept, 7);
        assert!((42.0..43.0).contains(&spent_s), "{spent_s} s");
        let (again, _) = ck
            .stage::<u32, ()>("revolution_dwell", |_, _| panic!("done already"))
            .unwrap();
        assert_eq!(again, 7);
    }

    #[test]
    fn off_keeps_nothing() {
        let mut ck = Checkpoints::off();
        ck.save("x", &1u8);
        assert!(!ck.due() && ck.load::<u8>("x").is_none());
    }
}
