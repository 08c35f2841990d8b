// The voxel model's step on a GPU: the same arithmetic as `kernel.rs` (the explicit update of
// the specific enthalpy h on the Kirchhoff potential Φ, losses from each voxel's exposed and
// table areas, then T and Φ from the new h in one table read), and what a step feeds the run
// (the ledger's loss sums, each laid deposit's mean temperature, its peak and time above the
// threshold). One dispatch per pass, in this order each step: `prologue` (the arc's heat into
// h; the deposit–plate interface's series correction, measured on the state as the step
// starts), `step` (the stencil), `bond` (the correction applied), `observe`. `scatter`
// writes voxels the host changed before a batch of steps.
//
// A field holds one or more members (a `follow` ensemble: one dispatch steps them all, the
// workgroup's z is the member). They share the geometry (the neighbour table, the areas, the
// interface pairs, the deposits' voxels); each has its own state (h, T, Φ at m·cap + v), its
// arc's heat, its losses, its peaks and its sums.

struct Params {
    n: u32,            // active voxels
    plate_end: u32,    // voxels below this step with the plate's tables (0: one material)
    n_sources: u32,
    n_pairs: u32,
    n_deps: u32,       // deposits laid: observed
    hot_slot: u32,     // this step's slot for the hottest laid metal
    n_records: u32,    // voxels to scatter
    cap: u32,          // capacity: the stride between faces in `nb` and between members' states
    dt: f32,
    dx: f32,
    ta: f32,
    ta4: f32,
    threshold: f32,
    cap_d: f32,        // dt / (ρ·dx³), deposit
    cap_p: f32,        // the plate's
    d_h0: f32,
    d_inv_dh: f32,
    d_last: f32,
    p_h0: f32,
    p_inv_dh: f32,
    p_last: f32,
    p_offset: u32,     // the plate's first entry in `tables`
    k_offset: u32,     // the plate's first entry in `conductivity`
    k_last: f32,       // last whole kelvin of each conductivity table
    nx: u32,           // workgroups along x: a dispatch wider than the device's limit wraps to y
    sy: u32,           // a regular voxel's neighbours across y and z: v ± sy, v ± sz
    sz: u32,
    src_cap: u32,      // per member: the stride of its sources, pairs' corrections, deposits
    pair_cap: u32,
    dep_cap: u32,
    acc_stride: u32,   // per member: workgroups of loss sums
    pad0: u32,
};

// A voxel the host wrote: its neighbours, exposed and table areas, and state.
struct Record {
    v: u32,
    m: u32,            // the member whose state it is (the geometry is everyone's)
    nb: array<u32, 6>,
    exposed: f32,
    table: f32,
    h: f32,
    t: f32,
    phi: f32,
};

// The arc's heat into one voxel, W; v = NONE pads a member's list to the longest.
struct Source {
    v: u32,
    w: f32,
};

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read_write> nb: array<u32>;      // face f of voxel v at f·cap + v
// (exposed, table), m² (a closed face leaves rounding: −1e−20 is no marker); (−1, 0) marks a regular voxel: all six neighbours active at v ± 1,
// v ± sy, v ± sz (the plate's inside, laid in grid order), nothing exposed: the step reads
// neither its neighbour table nor its temperature.
@group(0) @binding(2) var<storage, read_write> area: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> h: array<f32>;
@group(0) @binding(4) var<storage, read_write> t: array<f32>;
@group(0) @binding(5) var<storage, read_write> phi_in: array<f32>;
@group(0) @binding(6) var<storage, read_write> phi_out: array<f32>;
@group(0) @binding(7) var<storage, read> tables: array<vec2<f32>>;   // (T, Φ) on the h grid
@group(0) @binding(8) var<storage, read> conductivity: array<f32>;   // k at whole kelvins
@group(0) @binding(9) var<storage, read_write> acc: array<f32>;      // per workgroup: 3 sums, 3 carries
@group(0) @binding(10) var<storage, read> sources: array<Source>;
@group(0) @binding(11) var<storage, read> pairs: array<vec2<u32>>;   // (plate voxel, deposit voxel)
@group(0) @binding(12) var<storage, read_write> delta: array<f32>;   // per pair, W
@group(0) @binding(13) var<storage, read> dep_off: array<u32>;       // deposit i's voxels: dep_off[i]..dep_off[i+1]
@group(0) @binding(14) var<storage, read> dep_vox: array<u32>;
@group(0) @binding(15) var<storage, read_write> peak: array<f32>;
@group(0) @binding(16) var<storage, read_write> above: array<f32>;   // time above, since the last read
@group(0) @binding(17) var<storage, read_write> hot: array<atomic<u32>>; // per step slot
@group(0) @binding(18) var<storage, read> records: array<Record>;
@group(0) @binding(19) var<storage, read> losses: array<vec4<f32>>;  // per member: h_conv, εσ, h_table

const WG: u32 = 256u;
const SLOTS: u32 = 256u;
const NONE: u32 = 0xffffffffu;

fn index(wg: vec3<u32>, local: u32) -> u32 {
    return (wg.x + wg.y * p.nx) * WG + local;
}

// (T, Φ) at specific enthalpy x from one material's table (`kernel::Tables::at`).
fn lookup(x: f32, plate: bool) -> vec2<f32> {
    var h0 = p.d_h0;
    var inv_dh = p.d_inv_dh;
    var last = p.d_last;
    var base = 0u;
    if plate {
        h0 = p.p_h0;
        inv_dh = p.p_inv_dh;
        last = p.p_last;
        base = p.p_offset;
    }
    let u = clamp((x - h0) * inv_dh, 0.0, last);
    let i = u32(u);
    let f = u - f32(i);
    let a = tables[base + i];
    let b = tables[base + i + 1u];
    return a + f * (b - a);
}

fn k_of(temp: f32, plate: bool) -> f32 {
    let u = clamp(temp, 0.0, p.k_last);
    let i = min(u32(u), u32(p.k_last) - 1u);
    let f = u - f32(i);
    var base = 0u;
    if plate {
        base = p.k_offset;
    }
    let a = conductivity[base + i];
    return a + f * (conductivity[base + i + 1u] - a);
}

@compute @workgroup_size(256)
fn scatter(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) l: u32) {
    let r = index(wg, l);
    if r >= p.n_records {
        return;
    }
    let rec = records[r];
    for (var f = 0u; f < 6u; f++) {
        nb[f * p.cap + rec.v] = rec.nb[f];
    }
    area[rec.v] = vec2<f32>(rec.exposed, rec.table); // the host marks a regular voxel
    let v = rec.m * p.cap + rec.v;
    h[v] = rec.h;
    t[v] = rec.t;
    phi_in[v] = rec.phi;
    phi_out[v] = rec.phi;
}

// The arc's heat into h (the listed voxels are distinct), and each interface pair's correction
// on the state as the step starts: the series conductance 2·k_p·k_d/(k_p + k_d) on T less the
// stencil's own dx·(Φ_j − Φ_i).
@compute @workgroup_size(256)
fn prologue(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) l: u32) {
    let s = index(wg, l);
    let o = wg.z * p.cap;
    if s < p.n_sources {
        let src = sources[wg.z * p.src_cap + s];
        if src.v != NONE {
            var c = p.cap_d;
            if src.v < p.plate_end {
                c = p.cap_p;
            }
            h[o + src.v] = h[o + src.v] + c * src.w;
        }
    }
    if s < p.n_pairs {
        let ij = pairs[s] + vec2<u32>(o);
        let ti = t[ij.x];
        let tj = t[ij.y];
        let kp = k_of(ti, true);
        let kd = k_of(tj, false);
        let series = 2.0 * kp * kd / (kp + kd);
        delta[wg.z * p.pair_cap + s] = p.dx * series * (tj - ti) - p.dx * (phi_in[ij.y] - phi_in[ij.x]);
    }
}

var<workgroup> red: array<vec3<f32>, 256>;

@compute @workgroup_size(256)
fn step(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) l: u32) {
    let i = index(wg, l);
    let o = wg.z * p.cap;
    let v = o + i;
    var sums = vec3<f32>(0.0);
    if i < p.n {
        let ab = area[i];
        let plate = i < p.plate_end;
        var cap = p.cap_d;
        if plate {
            cap = p.cap_p;
        }
        var flux: f32;
        if ab.x < -0.5 {
            let ring = phi_in[v - 1u] + phi_in[v + 1u] + phi_in[v - p.sy] + phi_in[v + p.sy]
                + phi_in[v - p.sz] + phi_in[v + p.sz];
            flux = p.dx * (ring - 6.0 * phi_in[v]);
        } else {
            let c = p.cap;
            let ring = phi_in[o + nb[i]] + phi_in[o + nb[c + i]] + phi_in[o + nb[2u * c + i]]
                + phi_in[o + nb[3u * c + i]] + phi_in[o + nb[4u * c + i]] + phi_in[o + nb[5u * c + i]];
            let lap = ring - 6.0 * phi_in[v];
            let ti = t[v];
            let d = ti - p.ta;
            let t2 = ti * ti;
            let rad = t2 * t2 - p.ta4;
            let k = losses[wg.z];
            flux = p.dx * lap - (k.x * ab.x + k.z * ab.y) * d - k.y * ab.x * rad;
            sums = vec3<f32>(ab.x * d, ab.x * rad, ab.y * d);
        }
        let hv = h[v] + cap * flux;
        h[v] = hv;
        let tp = lookup(hv, plate);
        t[v] = tp.x;
        phi_out[v] = tp.y;
    }
    red[l] = sums;
    workgroupBarrier();
    for (var w = WG / 2u; w > 0u; w = w / 2u) {
        if l < w {
            red[l] = red[l] + red[l + w];
        }
        workgroupBarrier();
    }
    if l == 0u {
        // Kahan's compensated sum over the steps of a batch, times dt: the ledger's 1e-5.
        let g = (wg.z * p.acc_stride + wg.x + wg.y * p.nx) * 6u;
        let x = red[0] * p.dt;
        for (var k = 0u; k < 3u; k++) {
            let y = x[k] - acc[g + 3u + k];
            let s = acc[g + k] + y;
            acc[g + 3u + k] = (s - acc[g + k]) - y;
            acc[g + k] = s;
        }
    }
}

@compute @workgroup_size(256)
fn bond(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) l: u32) {
    let s = index(wg, l);
    if s >= p.n_pairs {
        return;
    }
    let ij = pairs[s] + vec2<u32>(wg.z * p.cap);
    let d = delta[wg.z * p.pair_cap + s];
    let hi = h[ij.x] + p.cap_p * d;
    let hj = h[ij.y] - p.cap_d * d;
    h[ij.x] = hi;
    h[ij.y] = hj;
    let a = lookup(hi, true);
    let b = lookup(hj, false);
    t[ij.x] = a.x;
    phi_out[ij.x] = a.y;
    t[ij.y] = b.x;
    phi_out[ij.y] = b.y;
}

// Each laid deposit's metal after the step: its mean temperature, its peak, its time above the
// threshold, and the hottest of them in this step's slot (temperatures are positive, so their
// bits order as they do).
@compute @workgroup_size(256)
fn observe(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) l: u32) {
    let i = index(wg, l);
    if i >= p.n_deps {
        return;
    }
    let lo = dep_off[i];
    let hi = dep_off[i + 1u];
    if hi == lo {
        return;
    }
    let o = wg.z * p.cap;
    var s = 0.0;
    for (var k = lo; k < hi; k++) {
        s += t[o + dep_vox[k]];
    }
    let m = s / f32(hi - lo);
    let j = wg.z * p.dep_cap + i;
    peak[j] = max(peak[j], m);
    if m > p.threshold {
        above[j] = above[j] + p.dt;
    }
    atomicMax(&hot[wg.z * SLOTS + p.hot_slot], bitcast<u32>(m));
}
