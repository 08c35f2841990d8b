//! Members of one field on the device, each run on a thread of its own ([`Batch`]): at each
//! read a member leaves its round and waits; the last to arrive runs every round as one batch
//! and hands each member its reply. A member's [`Seat`], dropped when its run ends, fails a
//! round the others began rather than leave them waiting.

use super::field::{Field, Parts, Reply, Round};
use super::lane::{Home, Lane};
use super::{Gpu, shared};
use crate::voxel::VoxelModel;
use std::sync::{Arc, Condvar, Mutex};

/// The members of one field on the device, each run on a thread of its own: at each read, a
/// member leaves its round and waits; the last to arrive runs every member's round as one
/// batch and hands each its reply.
pub(super) struct Batch {
    pub(super) gpu: Arc<Gpu>,
    pub(super) members: usize,
    turn: Mutex<Turn>,
    /// Signalled when a batch has run, or failed.
    done: Condvar,
}

/// The batch's state, under its lock: the field, this round's rounds and replies.
struct Turn {
    field: Option<Field>,
    rounds: Vec<Option<Round>>,
    replies: Vec<Option<Reply>>,
    /// Members whose run stopped since the batch was last begun.
    left: Vec<bool>,
    /// Why the batch failed: every member's run fails with it.
    failed: Option<String>,
    /// Batches run so far: a waiting member wakes when it moves.
    generation: u64,
}

impl Batch {
    pub(super) fn new(gpu: Arc<Gpu>, members: usize) -> Batch {
        Batch {
            gpu,
            members,
            turn: Mutex::new(Turn {
                field: None,
                rounds: (0..members).map(|_| None).collect(),
                replies: (0..members).map(|_| None).collect(),
                left: vec![false; members],
                failed: None,
                generation: 0,
            }),
            done: Condvar::new(),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Turn> {
        // A member that panicked holding the lock leaves the batch failed, not the others
        // panicking in turn.
        self.turn.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Every member back at the start: the next rounds may begin.
    pub(super) fn begin(&self) {
        self.lock().left.iter_mut().for_each(|l| *l = false);
    }

    /// Of the voxels on the device when the field was made, those stepped on the fast path.
    pub(super) fn regular(&self) -> Option<usize> {
        self.lock().field.as_ref().map(|f| f.regular)
    }

    /// Whether the field has room for `m`.
    pub(super) fn fits(&self, m: &VoxelModel) -> bool {
        self.lock().field.as_ref().is_some_and(|f| f.fits(m))
    }

    /// Member k's round: wait for the others', and the reply when the batch has run.
    pub(super) fn round(&self, k: usize, round: Round) -> Result<Reply, String> {
        let mut turn = self.lock();
        if let Some(e) = &turn.failed {
            return Err(e.clone());
        }
        if let Some(j) = turn.left.iter().position(|&l| l) {
            let e = format!("member {j} of the device's batch stopped before member {k} read");
            return Err(self.fail(&mut turn, e));
        }
        turn.rounds[k] = Some(round);
        if turn.rounds.iter().all(Option::is_some) {
            let rounds: Vec<Round> = turn.rounds.iter_mut().map(|r| r.take().unwrap()).collect();
            let mut replies: Vec<Option<Reply>> = (0..self.members).map(|_| None).collect();
            let mut deliver = |j: usize, p: Parts| replies[j] = Some(Reply::of(p));
            match self.run(&mut turn.field, rounds, &mut deliver) {
                Ok(()) => turn.replies = replies,
                Err(e) => {
                    self.fail(&mut turn, e);
                }
            }
            turn.generation += 1;
            self.done.notify_all();
        } else {
            let generation = turn.generation;
            while turn.generation == generation && turn.failed.is_none() {
                turn = self.done.wait(turn).unwrap_or_else(|e| e.into_inner());
            }
        }
        match (turn.replies[k].take(), &turn.failed) {
            (Some(r), _) => Ok(r),
            (None, Some(e)) => Err(e.clone()),
            (None, None) => Err(format!("the device's batch gave member {k} no reply")),
        }
    }

    /// The field made again where every round asks it, then the rounds run.
    fn run(
        &self,
        field: &mut Option<Field>,
        mut rounds: Vec<Round>,
        deliver: &mut dyn FnMut(usize, Parts),
    ) -> Result<(), String> {
        let remakes = rounds.iter().filter(|r| r.remake.is_some()).count();
        if remakes == self.members {
            let copies: Vec<(Box<VoxelModel>, Vec<f32>)> = rounds
                .iter_mut()
                .map(|r| r.remake.take().unwrap())
                .collect();
            let models: Vec<&VoxelModel> = copies.iter().map(|c| &*c.0).collect();
            let peaks: Vec<&[f32]> = copies.iter().map(|c| c.1.as_slice()).collect();
            *field = None;
            *field =
                Some(Field::new(self.gpu.clone(), &models, &peaks).map_err(|e| e.to_string())?);
        } else if remakes > 0 {
            return Err(format!(
                "the batch's members fell out of step: {remakes} of {} made the device's copy again",
                self.members
            ));
        }
        let f = field
            .as_mut()
            .ok_or("the device's batch has no copy of the field")?;
        f.run(&rounds, deliver)
    }

    /// The batch failed with `e` (or the failure before it): every member's run fails with it.
    fn fail(&self, turn: &mut Turn, e: String) -> String {
        let e = turn.failed.get_or_insert(e).clone();
        self.done.notify_all();
        e
    }

    /// Member k's run stopped: a round the others began cannot be run.
    fn leave(&self, k: usize) {
        let mut turn = self.lock();
        turn.left[k] = true;
        if turn.rounds.iter().any(Option::is_some) {
            let e = format!("member {k} of the device's batch stopped before the others read");
            self.fail(&mut turn, e);
        }
    }
}

/// A member's place in a batch, held by the thread that runs it: when it is dropped (the run
/// done, failed or panicked) a round the others began fails rather than waits.
pub struct Seat {
    batch: Arc<Batch>,
    k: usize,
}

impl Drop for Seat {
    fn drop(&mut self) {
        self.batch.leave(self.k);
    }
}

/// Put `models` on the device as one batch: runs of one program on one grid, each to be run
/// on a thread of its own holding its seat. A batch they already make is begun again.
pub(in crate::voxel) fn share(models: &mut [&mut VoxelModel]) -> Result<Vec<Seat>, String> {
    let members = models.len();
    let same = match &models[0].field.home {
        Home::Batch(b, 0) if b.members == members => Some(b.clone()),
        _ => None,
    };
    let batch = match same.filter(|b| {
        models.iter().enumerate().all(
            |(k, m)| matches!(&m.field.home, Home::Batch(c, j) if Arc::ptr_eq(b, c) && *j == k),
        )
    }) {
        Some(b) => {
            b.begin();
            b
        }
        None => {
            let batch = Arc::new(Batch::new(shared()?, members));
            for (k, m) in models.iter_mut().enumerate() {
                m.field = Lane {
                    home: Home::Batch(batch.clone(), k),
                    ..Lane::default()
                };
            }
            batch
        }
    };
    Ok((0..members)
        .map(|k| Seat {
            batch: batch.clone(),
            k,
        })
        .collect())
}
