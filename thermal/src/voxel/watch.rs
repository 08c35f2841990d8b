//! The laid metal read inside a step: each deposit's mean temperature, peak and time above the
//! hot threshold, taken by the task that stepped the chunk holding the deposit's voxels (they
//! are one run of the active set, deposits one after another in laying order), so that a step
//! hands work to the threads once (docs/PERFORMANCE.md, "Two cores"). A deposit across two
//! chunks is read after the step, from the whole field.

use super::CHUNK;
use crate::run::PointResult;
use std::ops::Range;

/// Each chunk's deposits' points, with the first's index (`Cut::pieces`).
pub(super) type Pieces<'p> = Vec<(usize, &'p mut [PointResult])>;

/// What a step reads of the laid metal (`VoxelModel::step_watched`): deposits 0..`laid`'s
/// peaks and times above the hot threshold, into `points`.
pub(super) struct Watch<'a> {
    pub(super) laid: usize,
    pub(super) points: &'a mut [PointResult],
}

/// Deposits' voxels as runs of the active set, in laying order (`VoxelModel::runs`), and the
/// last cut of them by chunks.
#[derive(Clone, Default)]
pub(super) struct Runs {
    pub(super) runs: Vec<Range<u32>>,
    /// Deposit `runs.len()`'s voxels are not one run after the last's: the step reads apart
    /// until it is laid again.
    broken: bool,
    cut: Option<Cut>,
}

/// Deposits 0..laid by the chunks of the active set: `bounds[j]` = (a, b), deposits a..b lie
/// wholly in chunk j; those between one chunk's b and the next's a lie across a boundary.
#[derive(Clone)]
pub(super) struct Cut {
    laid: usize,
    pub(super) bounds: Vec<(usize, usize)>,
}

impl Runs {
    /// Deposit i and after laid again: their runs taken anew.
    pub(super) fn forget_from(&mut self, i: usize) {
        if i < self.runs.len() {
            self.runs.truncate(i);
            self.cut = None;
        }
        // The deposit that broke the runs is the one after the last kept.
        if i <= self.runs.len() {
            self.broken = false;
        }
    }

    /// Deposits 0..laid by the `chunks` chunks, their runs taken from `lists` (`laid`) as
    /// needed; None where a list is not one ascending run at or after the last's end.
    pub(super) fn cut(&mut self, lists: &[Vec<u32>], laid: usize, chunks: usize) -> Option<Cut> {
        while !self.broken && self.runs.len() < laid {
            let end = self.runs.last().map_or(0, |r| r.end);
            let v = &lists[self.runs.len()];
            let run = match (v.first(), v.last()) {
                (Some(&a), Some(&b)) => a..b + 1,
                _ => end..end,
            };
            self.broken = run.start < end || v.windows(2).any(|w| w[1] != w[0] + 1);
            if !self.broken {
                self.runs.push(run);
            }
        }
        if self.broken {
            return None;
        }
        if let Some(c) = &self.cut
            && c.laid == laid
            && c.bounds.len() == chunks
        {
            return Some(c.clone());
        }
        let runs = &self.runs[..laid];
        let mut before = 0;
        let bounds = (0..chunks)
            .map(|j| {
                let (c0, c1) = ((j * CHUNK) as u32, ((j + 1) * CHUNK) as u32);
                let a = runs.partition_point(|r| r.start < c0).max(before);
                let b = runs.partition_point(|r| r.end <= c1).max(a);
                before = b;
                (a, b)
            })
            .collect();
        let cut = Cut { laid, bounds };
        self.cut = Some(cut.clone());
        Some(cut)
    }
}

impl Cut {
    /// Each chunk's deposits' points, with the first's index.
    pub(super) fn pieces<'p>(&self, points: &'p mut [PointResult]) -> Pieces<'p> {
        let (mut rest, mut at) = (points, 0);
        self.bounds
            .iter()
            .map(|&(a, b)| {
                let (_, tail) = std::mem::take(&mut rest).split_at_mut(a - at);
                let (mine, tail) = tail.split_at_mut(b - a);
                (rest, at) = (tail, b);
                (a, mine)
            })
            .collect()
    }

    /// The deposits across a chunk's boundary.
    pub(super) fn across(&self) -> impl Iterator<Item = usize> + '_ {
        let from = self.bounds.iter().map(|b| b.1);
        let to = self.bounds.iter().skip(1).map(|b| b.0).chain([self.laid]);
        from.zip(to).flat_map(|(s, e)| s..e.max(s))
    }
}

/// Peaks and times above `hot` of deposits `points` (their runs first in `runs`, `mean`
/// reading a run's mean temperature) after a step of dt; the hottest of them, NaN if none.
pub(super) fn watch_points(
    points: &mut [PointResult],
    runs: &[Range<u32>],
    hot: f64,
    dt: f64,
    mean: impl Fn(&Range<u32>) -> f64,
) -> f64 {
    points
        .iter_mut()
        .zip(runs)
        .fold(f64::NAN, |hottest, (p, r)| {
            if r.is_empty() {
                return hottest;
            }
            let t = mean(r);
            p.peak = p.peak.max(t);
            if t > hot {
                p.time_above += dt;
            }
            hottest.max(t)
        })
}

/// The mean of `t` in f64, summed in order (as `VoxelModel::mean_t`).
pub(super) fn mean_of(t: &[f32]) -> f64 {
    t.iter().map(|&x| x as f64).sum::<f64>() / t.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deposits cut by chunks: each deposit wholly in one chunk's piece or across a boundary,
    /// never both; a list out of order breaks the runs until that deposit is laid again.
    #[test]
    fn deposits_are_cut_by_chunks() {
        // Deposits of 1000 voxels after a plate of 3000, one empty, over chunks of CHUNK.
        let mut lists: Vec<Vec<u32>> = Vec::new();
        let mut next = 3000u32;
        for k in 0..40 {
            let n = if k == 7 { 0 } else { 1000 };
            lists.push((next..next + n).collect());
            next += n;
        }
        let chunks = (next as usize).div_ceil(CHUNK);
        let mut runs = Runs::default();
        let cut = runs.cut(&lists, lists.len(), chunks).unwrap();
        let mut seen = vec![0; lists.len()];
        for (j, &(a, b)) in cut.bounds.iter().enumerate() {
            for (n, r) in seen[a..b].iter_mut().zip(&runs.runs[a..b]) {
                *n += 1;
                assert!(r.start as usize >= j * CHUNK && r.end as usize <= (j + 1) * CHUNK);
            }
        }
        for k in cut.across() {
            seen[k] += 1;
            let r = &runs.runs[k];
            assert!(
                r.start as usize / CHUNK != (r.end as usize - 1) / CHUNK,
                "{k}: {r:?}"
            );
        }
        assert!(seen.iter().all(|&n| n == 1), "{seen:?}");
        assert!(cut.across().count() >= 9);

        let mut scrambled = lists.clone();
        scrambled[20].swap(0, 1);
        let mut runs = Runs::default();
        assert!(runs.cut(&scrambled, 40, chunks).is_none());
        runs.forget_from(30);
        assert!(runs.cut(&scrambled, 40, chunks).is_none());
        assert!(runs.cut(&scrambled, 20, chunks).is_none());
        runs.forget_from(20);
        assert!(runs.cut(&lists, 40, chunks).is_some());
    }
}
