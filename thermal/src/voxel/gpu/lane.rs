//! A model's way to the device ([`Lane`]): where its steps go (a field of its own, or a place
//! in a batch), what the device has of it, the steps recorded since the last read; and the
//! model's calls that use it (make the device's copy, record a step, read back).

use super::batch::Batch;
use super::field::{Changes, Field, Params, Parts, Record, Round, Step};
use super::field::{area_of, interface_len, losses_of, strides};
use super::{Read, SLOTS, shared};
use crate::error::ThermalError;
use crate::network::SIGMA;
use crate::run::{Hottest, PointResult};
use crate::voxel::VoxelModel;
use std::sync::Arc;

/// Where a model's steps go.
#[derive(Default)]
pub(super) enum Home {
    /// Nowhere yet: a field is made at the next call.
    #[default]
    None,
    /// A field of its own.
    Alone(Box<Field>),
    /// Member k of a batch.
    Batch(Arc<Batch>, usize),
}

/// What the device has of a model (its lane's side of the rule): the geometry, the arc's heat
/// and the losses last sent.
#[derive(Default)]
pub(super) struct Sent {
    pub(super) n: usize,
    pub(super) pairs: usize,
    pub(super) deps: usize,
    pub(super) strides: [u32; 2],
    pub(super) sources: Vec<(u32, f32)>,
    pub(super) losses: [f32; 4],
}

/// A model's way to the device: where its steps go, what the device has of it, the steps
/// recorded since the last read (with the time at each one's end), and the device's first
/// failure, which ends the run at its next check. A clone has none of it: it makes its own
/// from the host's copy, which is current between calls.
#[derive(Default)]
pub(in crate::voxel) struct Lane {
    pub(super) home: Home,
    pub(super) sent: Sent,
    pub(super) steps: Vec<Step>,
    pub(super) times: Vec<f64>,
    /// In a batch: the next round makes the field again from this copy.
    pub(super) remake: Option<(Box<VoxelModel>, Vec<f32>)>,
    pub(super) failure: Option<String>,
}

impl Clone for Lane {
    fn clone(&self) -> Lane {
        Lane::default()
    }
}

impl VoxelModel {
    /// What the device will have of this model once a field is made from it.
    pub(super) fn sent_now(&self) -> Sent {
        Sent {
            n: self.h.len(),
            pairs: interface_len(self),
            deps: 0,
            strides: strides(self),
            sources: Vec::new(),
            losses: losses_of(self),
        }
    }

    pub(super) fn peaks(points: &[PointResult]) -> Vec<f32> {
        points.iter().map(|p| p.peak as f32).collect()
    }

    /// Make the device's copy where there is none (or it has outgrown its buffers), from the
    /// host's; `points` give the deposits' peaks so far. The host's copy must be current (a
    /// call's start: no steps recorded).
    pub(in crate::voxel) fn gpu_ready(
        &mut self,
        points: &[PointResult],
    ) -> Result<(), ThermalError> {
        debug_assert!(self.field.steps.is_empty());
        match &self.field.home {
            Home::Alone(f) if f.fits(self) => return Ok(()),
            Home::Batch(b, _) if self.field.remake.is_none() && b.fits(self) => return Ok(()),
            Home::Batch(..) => {
                let copy = (Box::new(self.clone()), VoxelModel::peaks(points));
                self.field.remake = Some(copy);
            }
            Home::None | Home::Alone(_) => {
                let gpu = shared().map_err(|reason| ThermalError::Device { reason })?;
                let field = Field::new(gpu, &[self], &[&VoxelModel::peaks(points)])?;
                self.field.home = Home::Alone(Box::new(field));
            }
        }
        self.field.sent = self.sent_now();
        self.dirty.clear();
        Ok(())
    }

    /// Everything on the device to be written again: a lone run's copy is dropped; a member
    /// of a batch sends every voxel.
    pub(in crate::voxel) fn gpu_all_dirty(&mut self) {
        match self.field.home {
            Home::Batch(..) => self.dirty = (0..self.h.len() as u32).collect(),
            _ => {
                self.field.home = Home::None;
                self.dirty.clear();
            }
        }
    }

    /// What the host changed since the device last heard from it, against `sent`.
    pub(super) fn changes(&mut self, source: &[(u32, f32)], laid: usize) -> Option<Changes> {
        let sent = &self.field.sent;
        let new_pairs = match self.substrate.as_deref() {
            Some(s) if s.interface.len() > sent.pairs => s.interface[sent.pairs..]
                .iter()
                .map(|&(i, j)| [i, j])
                .collect(),
            _ => Vec::new(),
        };
        let laid_new: Vec<Vec<u32>> = match laid > sent.deps {
            true => self.laid[sent.deps..laid].to_vec(),
            false => Vec::new(),
        };
        let sources = (source != sent.sources.as_slice()).then(|| {
            let mut sorted = source.to_vec();
            sorted.sort_by_key(|s| s.0);
            let mut merged: Vec<(u32, f32)> = Vec::with_capacity(sorted.len());
            for (v, w) in sorted {
                match merged.last_mut() {
                    Some(last) if last.0 == v => last.1 += w,
                    _ => merged.push((v, w)),
                }
            }
            merged.iter().map(|&(v, w)| [v, w.to_bits()]).collect()
        });
        let losses = losses_of(self);
        let losses = (losses != sent.losses).then_some(losses);
        let records: Vec<Record> = self
            .dirty
            .iter()
            .map(|&v| {
                let i = v as usize;
                let [exposed, table] = area_of(self, i, sent.strides);
                Record {
                    v,
                    m: 0,
                    nb: std::array::from_fn(|f| self.neighbours[f][i]),
                    exposed,
                    table,
                    h: self.h[i],
                    t: self.t[i],
                    phi: self.phi[i],
                }
            })
            .collect();
        let grown = self.h.len() != sent.n;
        let unchanged = !grown
            && records.is_empty()
            && new_pairs.is_empty()
            && laid_new.is_empty()
            && sources.is_none()
            && losses.is_none();
        if unchanged {
            return None;
        }
        let sent = &mut self.field.sent;
        sent.n = self.h.len();
        sent.pairs += new_pairs.len();
        sent.deps += laid_new.len();
        if sources.is_some() {
            sent.sources = source.to_vec();
        }
        if let Some(l) = losses {
            sent.losses = l;
        }
        self.dirty.clear();
        Some(Changes {
            records,
            pairs: new_pairs,
            laid: laid_new,
            sources,
            losses,
        })
    }

    /// Record one step of dt on the device with `source` watts, deposits 0..laid observed;
    /// `now` is the time at its end. The ledger's source and counts are booked here, its
    /// losses when the device is read.
    pub(in crate::voxel) fn gpu_step(
        &mut self,
        dt: f64,
        source: &[(u32, f32)],
        laid: usize,
        now: f64,
    ) {
        let changes = self.changes(source, laid);
        let [_, cp, c] = self.coefficients(dt);
        let plate = self
            .substrate
            .as_deref()
            .map_or(&self.tables, |s| &s.tables);
        let p = Params {
            n_deps: laid as u32,
            plate_end: match self.substrate {
                Some(_) => self.plate_voxels as u32,
                None => 0,
            },
            dt: dt as f32,
            dx: c.dx,
            ta: c.ta,
            ta4: c.ta4,
            threshold: self.settings.hot_threshold as f32,
            cap_d: c.inv_cap,
            cap_p: cp.inv_cap,
            d_h0: self.tables.h0,
            d_inv_dh: self.tables.inv_dh,
            d_last: self.tables.last,
            p_h0: plate.h0,
            p_inv_dh: plate.inv_dh,
            p_last: plate.last,
            p_offset: self.tables.t_phi.len() as u32,
            ..Params::default()
        };
        let sent = &self.field.sent;
        self.field.steps.push(Step {
            shape: [sent.n, sent.pairs, sent.deps],
            changes,
            p,
        });
        self.field.times.push(now);
        self.ledger.source += dt * source.iter().map(|&(_, w)| w as f64).sum::<f64>();
        self.updates += self.h.len() as u64;
        self.steps += 1;
    }

    /// Whether the steps recorded fill the device's slots for the hottest metal: the run
    /// reads it then.
    pub(in crate::voxel) fn gpu_full(&self) -> bool {
        self.field.steps.len() >= SLOTS
    }

    /// Send the steps recorded to the device and read it back: the losses into the ledger,
    /// the hottest laid metal of each step into `hottest` (when `on`), and what `what` asks
    /// into the host's copy (the deposits' peaks and times above into `points`).
    pub(in crate::voxel) fn gpu_read(
        &mut self,
        points: &mut [PointResult],
        hottest: &mut Hottest,
        on: bool,
        what: Read,
    ) {
        let round = Round {
            remake: self.field.remake.take(),
            steps: std::mem::take(&mut self.field.steps),
            what,
        };
        let times = std::mem::take(&mut self.field.times);
        let mut home = std::mem::take(&mut self.field.home);
        let done = match &mut home {
            Home::None => Ok(()),
            Home::Alone(field) => field.run(std::slice::from_ref(&round), &mut |_, parts| {
                self.take_reply(parts, points, hottest, on, what, &times)
            }),
            Home::Batch(batch, k) => batch
                .round(*k, round)
                .map(|r| self.take_reply(r.parts(), points, hottest, on, what, &times)),
        };
        self.field.home = home;
        if let Err(reason) = done {
            self.field.failure.get_or_insert(reason);
        }
    }

    /// A read's reply into the host's copy: the temperatures (and with `All` the whole field,
    /// each deposit's peak and time above into `points`), each step's hottest laid metal at
    /// `times` into `hottest` (when `on`), the losses into the ledger.
    pub(super) fn take_reply(
        &mut self,
        r: Parts,
        points: &mut [PointResult],
        hottest: &mut Hottest,
        on: bool,
        what: Read,
        times: &[f64],
    ) {
        if !r.t.is_empty() {
            copy(&mut self.t, r.t);
        }
        if what == Read::All {
            copy(&mut self.h, r.h);
            copy(&mut self.phi, r.phi);
            copy(&mut self.phi_next, r.phi);
            for ((pt, &pk), &up) in points.iter_mut().zip(r.peak).zip(r.above) {
                pt.peak = pt.peak.max(pk as f64);
                pt.time_above += up as f64;
            }
        }
        for (&now, &bits) in times.iter().zip(r.hot) {
            let t = match bits.to_bits() {
                0 => f64::NAN,
                b => f32::from_bits(b) as f64,
            };
            hottest.push(on, now, t);
        }
        let sur = self.settings.surroundings;
        self.ledger.convection += sur.convection_w_m2k as f32 as f64 * r.sums[0];
        self.ledger.radiation += (sur.emissivity * SIGMA) as f32 as f64 * r.sums[1];
        self.ledger.table += sur.table_w_m2k as f32 as f64 * r.sums[2];
    }

    /// Why the device failed, if it did (a device lost, a read that did not come back, a
    /// batch whose members fell out of step).
    pub(in crate::voxel) fn gpu_failure(&self) -> Option<&str> {
        self.field.failure.as_deref()
    }

    /// The adapter's name, where the model has a device.
    pub fn gpu_name(&self) -> Option<String> {
        match &self.field.home {
            Home::None => None,
            Home::Alone(f) => Some(f.gpu.name.clone()),
            Home::Batch(b, _) => Some(b.gpu.name.clone()),
        }
    }

    /// Of the voxels on the device when its copy was made, those it steps without reading
    /// their neighbour table (`area_of`), where the model has a device.
    pub fn gpu_regular(&self) -> Option<usize> {
        match &self.field.home {
            Home::None => None,
            Home::Alone(f) => Some(f.regular),
            Home::Batch(b, _) => b.regular(),
        }
    }
}

/// `dst` ← `src` in pieces on every thread: the field read back at each call's end is copied out
/// of the mapped buffer at one core's memory bandwidth otherwise (on the H200's machine it was a
/// third of a dome's time, docs/PERFORMANCE.md "Where a GPU step's time goes").
fn copy(dst: &mut [f32], src: &[f32]) {
    use rayon::prelude::*;
    const PIECE: usize = 1 << 16;
    assert_eq!(
        dst.len(),
        src.len(),
        "the device's copy and the host's differ in length"
    );
    dst.par_chunks_mut(PIECE)
        .zip(src.par_chunks(PIECE))
        .for_each(|(d, s)| d.copy_from_slice(s));
}
