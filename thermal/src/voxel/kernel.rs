//! The voxel model's explicit step on the Kirchhoff potential: one pass over a chunk of the
//! active set, h += dt/(ρ·dx³)·(dx·Σ_faces (Φ_nb − Φ_v) − losses), then T and Φ read from the
//! new h in one table. Written twice: plain Rust, and eight voxels at a time with AVX2 and FMA
//! where the processor has them (chosen at run time: the x86-64 baseline this project builds for
//! has neither). The vector kernel reads neighbours that are consecutive voxels with one load and
//! the others, and the table, with scalar loads: on this machine's AMD processor hardware gathers
//! made the kernel more than twice as slow (4.2 against 1.8 ns an update, docs/PERFORMANCE.md). The two kernels agree to f32 rounding
//! (unit test); one machine always takes the same one, so results are the same on one thread or
//! two.

use crate::material::Material;

/// f32 lookup tables on a uniform enthalpy grid: temperature T(h) and the Kirchhoff potential
/// Φ(h) = ∫_{T_ambient}^{T(h)} k(τ) dτ (W/m). With Φ the conduction between two voxels is
/// dx·(Φ_j − Φ_i), exact for steady 1-D conduction whatever k(T) does (Carslaw and Jaeger 1959
/// §1.7): the heat equation ρ·∂h/∂t = ∇²Φ becomes a linear stencil on Φ, and the only
/// nonlinearity left is one table read per voxel. Interpolation error below 0.01 K.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub(super) struct Tables {
    pub(super) h0: f32,
    pub(super) inv_dh: f32,
    /// Largest index a read may start at (len − 2), as f32 for the clamp.
    pub(super) last: f32,
    /// (T, Φ) pairs: a read takes both values from one place.
    pub(super) t_phi: Vec<[f32; 2]>,
}

impl Tables {
    pub(super) fn new(m: &Material, ambient: f64) -> Tables {
        let (h0, h1) = (m.enthalpy(0.0), m.enthalpy(3999.0));
        let n = 1 << 16;
        let dh = (h1 - h0) / (n - 1) as f64;
        let temps: Vec<f64> = (0..n).map(|j| m.temperature(h0 + j as f64 * dh)).collect();
        let phi = kirchhoff(m, ambient, &temps);
        Tables {
            h0: h0 as f32,
            inv_dh: (1.0 / dh) as f32,
            last: (n - 2) as f32,
            t_phi: temps
                .iter()
                .zip(&phi)
                .map(|(&t, &p)| [t as f32, p as f32])
                .collect(),
        }
    }

    /// (T, Φ) at specific enthalpy h.
    #[inline(always)]
    pub(super) fn at(&self, h: f32) -> (f32, f32) {
        let x = ((h - self.h0) * self.inv_dh).clamp(0.0, self.last);
        // Through i32: one truncating conversion (x is small and non-negative).
        let i = x as i32;
        let f = x - i as f32;
        let (a, b) = (self.t_phi[i as usize], self.t_phi[i as usize + 1]);
        (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]))
    }
}

/// Φ(T) = ∫_{T_a}^{T} k dτ at each temperature of `temps` (K). k is linear between whole
/// kelvins (the material's tables), so the integral is summed exactly: whole kelvins by the
/// trapezoid rule, the fraction by the quadratic it makes.
fn kirchhoff(m: &Material, ambient: f64, temps: &[f64]) -> Vec<f64> {
    let top = temps.iter().fold(ambient, |a, &t| a.max(t)).ceil() as usize + 1;
    let mut whole = vec![0.0; top + 1];
    for i in 1..=top {
        whole[i] = whole[i - 1] + 0.5 * (m.conductivity((i - 1) as f64) + m.conductivity(i as f64));
    }
    let from_zero = |t: f64| {
        let t = t.max(0.0);
        let i = t.floor() as usize;
        let f = t - i as f64;
        let (k0, k1) = (m.conductivity(i as f64), m.conductivity(i as f64 + 1.0));
        whole[i] + k0 * f + 0.5 * (k1 - k0) * f * f
    };
    let base = from_zero(ambient);
    temps.iter().map(|&t| from_zero(t) - base).collect()
}

/// Constants of one explicit step.
#[derive(Clone, Copy)]
pub(super) struct Coefficients {
    /// dt / (ρ·dx³), s/kg.
    pub inv_cap: f32,
    pub dx: f32,
    pub ta: f32,
    pub ta4: f32,
    pub h_conv: f32,
    pub eps_sigma: f32,
    pub h_table: f32,
    /// Face area dx², m².
    pub area: f32,
}

/// Eight consecutive voxels (8g … 8g + 7) as the vector kernel reads them. Where the eight
/// neighbours across a face are themselves consecutive voxels (everywhere in the plate, and
/// wherever metal was laid in grid order) the face is `regular`: one load at `base` reads them
/// and the kernel streams 4 bytes for the face instead of 32.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct Group {
    /// The first voxel's neighbour across each face.
    pub base: [u32; 6],
    /// Bit f: the neighbours across face f are base[f] … base[f] + 7.
    pub regular: u8,
    /// Bit k: voxel 8g + k lies on the table.
    pub on_table: u8,
}

impl Group {
    /// The group of the eight voxels from `first` on.
    pub(super) fn of(neighbours: &[Vec<u32>; 6], on_table: &[f32], first: usize) -> Group {
        let mut g = Group {
            base: [0; 6],
            regular: 0,
            on_table: 0,
        };
        for (f, nb) in neighbours.iter().enumerate() {
            let run = &nb[first..first + 8];
            g.base[f] = run[0];
            if run.iter().zip(run[0]..).all(|(&u, want)| u == want) {
                g.regular |= 1 << f;
            }
        }
        for (k, &a) in on_table[first..first + 8].iter().enumerate() {
            if a > 0.0 {
                g.on_table |= 1 << k;
            }
        }
        g
    }
}

/// What the kernel reads over one chunk: the six neighbour indices of each voxel (−x, +x, −y,
/// +y, −z, +z; a voxel's own index where it has none), the chunk's whole groups, and each
/// voxel's exposed and table areas, m².
pub(super) struct Geometry<'a> {
    pub neighbours: [&'a [u32]; 6],
    pub groups: &'a [Group],
    pub exposed: &'a [f32],
    pub table: &'a [f32],
}

/// The state of one chunk, updated in place but for Φ, which neighbours read: the new Φ goes to
/// `phi_next`.
pub(super) struct Chunk<'a> {
    /// Active index of the chunk's first voxel.
    pub first: usize,
    pub h: &'a mut [f32],
    pub t: &'a mut [f32],
    pub phi_next: &'a mut [f32],
}

/// One step over a chunk, reading Φ of the whole active set. Returns the chunk's
/// Σ exposed·(T − T_a), Σ exposed·(T⁴ − T_a⁴) and Σ table·(T − T_a), for the energy ledger.
///
/// # Safety
/// Every index in `g.neighbours` is below `phi.len()` (the vector kernel does not check it), and
/// `simd` is true only where `simd_available()` is.
pub(super) unsafe fn update(
    c: &Coefficients,
    tables: &Tables,
    phi: &[f32],
    g: &Geometry,
    s: Chunk,
    simd: bool,
) -> [f32; 3] {
    let n = s.h.len();
    assert!(s.t.len() == n && s.phi_next.len() == n && g.exposed.len() == n);
    assert!(g.table.len() == n && s.first + n <= phi.len());
    assert!(g.neighbours.iter().all(|nb| nb.len() == n) && g.groups.len() <= n / 8);
    debug_assert!(
        g.neighbours
            .iter()
            .flat_map(|nb| nb.iter())
            .all(|&u| (u as usize) < phi.len())
    );
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: the processor has AVX2 and FMA and the indices are in range (the caller's
        // promise); the lengths are checked above.
        return unsafe { avx2::update(c, tables, phi, g, s) };
    }
    let _ = simd;
    scalar(c, tables, phi, g, s, 0)
}

/// Whether this processor runs the AVX2 kernel.
pub(super) fn simd_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The plain kernel from voxel `from` of the chunk on.
fn scalar(
    c: &Coefficients,
    tables: &Tables,
    phi: &[f32],
    g: &Geometry,
    s: Chunk,
    from: usize,
) -> [f32; 3] {
    let mut sums = [0.0f32; 3];
    let nb = &g.neighbours;
    for o in from..s.h.len() {
        let lap = phi[nb[0][o] as usize]
            + phi[nb[1][o] as usize]
            + phi[nb[2][o] as usize]
            + phi[nb[3][o] as usize]
            + phi[nb[4][o] as usize]
            + phi[nb[5][o] as usize]
            - 6.0 * phi[s.first + o];
        let ti = s.t[o];
        let d = ti - c.ta;
        let t2 = ti * ti;
        let rad = t2 * t2 - c.ta4;
        let (a, b) = (g.exposed[o], g.table[o]);
        let flux = c.dx * lap - (c.h_conv * a + c.h_table * b) * d - c.eps_sigma * a * rad;
        s.h[o] += c.inv_cap * flux;
        (s.t[o], s.phi_next[o]) = tables.at(s.h[o]);
        sums[0] += a * d;
        sums[1] += a * rad;
        sums[2] += b * d;
    }
    sums
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Chunk, Coefficients, Geometry, Tables};
    use std::arch::x86_64::*;

    /// The same arithmetic as `scalar`, a group of eight voxels at a time; the tail (the last
    /// voxels that make no whole group) goes to `scalar`.
    ///
    /// # Safety
    /// The processor has AVX2 and FMA; every neighbour index, and every regular group's
    /// base + 7, is below `phi.len()`; the chunk's slices have the lengths `update` checks.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn update(
        c: &Coefficients,
        tables: &Tables,
        phi: &[f32],
        g: &Geometry,
        s: Chunk,
    ) -> [f32; 3] {
        // SAFETY: the function's contract: loads and stores stay inside the chunk's slices
        // (8 · groups ≤ n), neighbour reads inside Φ, table reads inside the table (i ≤ last).
        unsafe {
            let set = _mm256_set1_ps;
            let (ta, ta4, dx, inv_cap) = (set(c.ta), set(c.ta4), set(c.dx), set(c.inv_cap));
            let (h_conv, h_table, eps_sigma) = (set(c.h_conv), set(c.h_table), set(c.eps_sigma));
            let (h0, inv_dh, last, six) = (
                set(tables.h0),
                set(tables.inv_dh),
                set(tables.last),
                set(6.0),
            );
            let (area, bits) = (set(c.area), _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128));
            let table = tables.t_phi.as_ptr() as *const f32;
            let (p, own) = (phi.as_ptr(), phi.as_ptr().add(s.first));
            let mut sums = [_mm256_setzero_ps(); 3];
            for (j, group) in g.groups.iter().enumerate() {
                let o = 8 * j;
                let across = |f: usize| {
                    if group.regular & (1 << f) != 0 {
                        _mm256_loadu_ps(p.add(group.base[f] as usize))
                    } else {
                        let u = |k: usize| *p.add(*g.neighbours[f].get_unchecked(o + k) as usize);
                        _mm256_setr_ps(u(0), u(1), u(2), u(3), u(4), u(5), u(6), u(7))
                    }
                };
                let ring = _mm256_add_ps(
                    _mm256_add_ps(_mm256_add_ps(across(0), across(1)), across(2)),
                    _mm256_add_ps(_mm256_add_ps(across(3), across(4)), across(5)),
                );
                let lap = _mm256_fnmadd_ps(six, _mm256_loadu_ps(own.add(o)), ring);
                let t = _mm256_loadu_ps(s.t.as_ptr().add(o));
                let d = _mm256_sub_ps(t, ta);
                let t2 = _mm256_mul_ps(t, t);
                let rad = _mm256_sub_ps(_mm256_mul_ps(t2, t2), ta4);
                let a = _mm256_loadu_ps(g.exposed.as_ptr().add(o));
                let on = _mm256_and_si256(_mm256_set1_epi32(group.on_table as i32), bits);
                let b = _mm256_and_ps(area, _mm256_castsi256_ps(_mm256_cmpeq_epi32(on, bits)));
                let lin = _mm256_mul_ps(_mm256_fmadd_ps(h_conv, a, _mm256_mul_ps(h_table, b)), d);
                let loss = _mm256_fmadd_ps(_mm256_mul_ps(eps_sigma, a), rad, lin);
                let flux = _mm256_fmsub_ps(dx, lap, loss);
                let hp = s.h.as_mut_ptr().add(o);
                let h = _mm256_fmadd_ps(inv_cap, flux, _mm256_loadu_ps(hp));
                _mm256_storeu_ps(hp, h);
                // The table read: x = (h − h0)/dh clamped, i = ⌊x⌋, the (T, Φ) pairs at i and
                // i + 1.
                let x = _mm256_mul_ps(_mm256_sub_ps(h, h0), inv_dh);
                let x = _mm256_min_ps(_mm256_max_ps(x, _mm256_setzero_ps()), last);
                let i = _mm256_cvttps_epi32(x);
                let f = _mm256_sub_ps(x, _mm256_cvtepi32_ps(i));
                // Eight 16-byte loads of (T_i, Φ_i, T_i+1, Φ_i+1), transposed to four vectors.
                let mut at = [0i32; 8];
                _mm256_storeu_si256(at.as_mut_ptr() as *mut __m256i, _mm256_slli_epi32::<1>(i));
                let row = |k: usize| _mm_loadu_ps(table.add(at[k] as usize));
                let r04 = _mm256_set_m128(row(4), row(0));
                let r15 = _mm256_set_m128(row(5), row(1));
                let r26 = _mm256_set_m128(row(6), row(2));
                let r37 = _mm256_set_m128(row(7), row(3));
                let lo01 = _mm256_unpacklo_ps(r04, r15);
                let hi01 = _mm256_unpackhi_ps(r04, r15);
                let lo23 = _mm256_unpacklo_ps(r26, r37);
                let hi23 = _mm256_unpackhi_ps(r26, r37);
                let halves = |a: __m256, b: __m256| {
                    let (a, b) = (_mm256_castps_pd(a), _mm256_castps_pd(b));
                    let lo = _mm256_castpd_ps(_mm256_unpacklo_pd(a, b));
                    (lo, _mm256_castpd_ps(_mm256_unpackhi_pd(a, b)))
                };
                let (t0, p0) = halves(lo01, lo23);
                let (t1, p1) = halves(hi01, hi23);
                let lerp = |a, b| _mm256_fmadd_ps(f, _mm256_sub_ps(b, a), a);
                _mm256_storeu_ps(s.t.as_mut_ptr().add(o), lerp(t0, t1));
                _mm256_storeu_ps(s.phi_next.as_mut_ptr().add(o), lerp(p0, p1));
                sums[0] = _mm256_fmadd_ps(a, d, sums[0]);
                sums[1] = _mm256_fmadd_ps(a, rad, sums[1]);
                sums[2] = _mm256_fmadd_ps(b, d, sums[2]);
            }
            let mut out = sums.map(|v| {
                let mut lanes = [0.0f32; 8];
                _mm256_storeu_ps(lanes.as_mut_ptr(), v);
                lanes.iter().sum::<f32>()
            });
            let tail = super::scalar(c, tables, phi, g, s, 8 * g.groups.len());
            for (x, y) in out.iter_mut().zip(tail) {
                *x += y;
            }
            out
        }
    }
}
