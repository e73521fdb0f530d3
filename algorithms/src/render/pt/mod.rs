//! Projected tetrahedra: classification of a tet's projection (one source of truth for the CPU
//! and GPU renderers) and the fan rasterizer of `cpu-pt`.
//!
//! **Fixed point.** Projected vertices are snapped to a grid of 1/[`SUBPIXEL`] pixel
//! ([`snap`]). Every decision — the four sign tests, the fan, which pixel centre a triangle
//! covers — is then exact integer arithmetic on the snapped points, so the sign pattern is
//! always one a real configuration of four points has (the 30 impossible entries of the table
//! never occur), every fan tiles its silhouette exactly, and two tets sharing a vertex snap it
//! identically (no cracks between cells).
//!
//! **The four tests** (PTINT: Marroquim, Maximo, Farias & Esperança 2006, Fig. 3) on the
//! projected vertices v0..v3: `t1 = (v1−v0)×(v2−v0)`, `t2 = (v1−v0)×(v3−v0)`,
//! `t3 = (v2−v0)×(v3−v0)`, `t4 = (v1−v2)×(v1−v3)`, i.e. the orientations o(0,1,2), o(0,1,3),
//! o(0,2,3), o(1,2,3) of the four triangles of the tet's vertices. Each is −, 0 or + (PTINT
//! eq. 3: 0, 1, 2) and the table index is `Σ (sign(t_i) + 1)·3^(i−1)` (t1 least significant).
//!
//! **The Radon point.** With `w = (t4, −t3, t2, −t1)` the four points satisfy the affine
//! dependency `Σ w_k·(1, v_k) = 0` (Laplace expansion of a 4×4 determinant with a repeated
//! column). Let A be the vertices of the minority sign of `w` and B those of the other non-zero
//! sign; then `Σ_A w_k v_k / Σ_A w_k = Σ_B w_k v_k / Σ_B w_k`: one point, in the convex hull of A
//! and in that of B — the thick vertex. That covers every class at once:
//! - class 1 (w signs 1:3): A = {the vertex inside the triangle B}; 3 triangles;
//! - class 2 (2:2): A and B are the two crossing edges, the thick vertex their crossing; 4;
//! - class 3 (one w = 0, signs 1:2): the three vertices other than the zero one are collinear,
//!   A = {the middle one}, lying on the silhouette edge B; 2 triangles;
//! - class 4 (two w = 0, signs 1:1): A and B project to the same point; 1 triangle;
//! - all four w = 0: the four points are collinear (a flat tet); discarded;
//! - any other pattern (all non-zero signs equal) is impossible.
//!
//! The ray through the thick vertex meets the tet in the segment from the point of A's hull to
//! the point of B's hull (a vertex, an edge point or a face point), which gives `s_f`, `s_b` and
//! the thickness `l` (Shirley & Tuchman 1990; PTINT §2).

mod faces;
mod raster;
mod small_tet;
mod tet_raster;
pub mod wgsl;

pub use faces::{fan_segment, FaceSegment, FaceVertex};
pub use raster::{
    pixel_box, pixel_box_i32, pixel_box_in, raster_fan, raster_fan_rows, FanGeometry, Fragment, Row,
};
pub use small_tet::{hull_misses_centres, hull_misses_centres_in, Fit, SmallTet};
pub use tet_raster::{fan_bits, wedge, TetRaster, TetRow, MAX_FAN};

use glam::DVec3;

// The fixed-point grid belongs to the camera (XMPVO's exterior order snaps to it too).
pub use crate::camera::{pixel_centre, snap, MAX_PIXEL_COORD, SUBPIXEL, SUBPIXEL_BITS};

/// Orientation `(b − a) × (c − a)` of snapped points; exact for |coordinates| ≤ 2^30.
#[inline]
pub fn orient(a: [i64; 2], b: [i64; 2], c: [i64; 2]) -> i64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// The four tests of PTINT Fig. 3 (t1..t4) on snapped points.
#[inline]
pub fn tests(q: &[[i64; 2]; 4]) -> [i64; 4] {
    let [v0, v1, v2, v3] = *q;
    let cross = |a: [i64; 2], b: [i64; 2]| a[0] * b[1] - a[1] * b[0];
    let sub = |a: [i64; 2], b: [i64; 2]| [a[0] - b[0], a[1] - b[1]];
    let (vec1, vec2, vec3) = (sub(v1, v0), sub(v2, v0), sub(v3, v0));
    let (vec4, vec5) = (sub(v1, v2), sub(v1, v3));
    [
        cross(vec1, vec2),
        cross(vec1, vec3),
        cross(vec2, vec3),
        cross(vec4, vec5),
    ]
}

/// Index into [`TABLE`] of the four tests: `Σ (sign(t_i) + 1)·3^(i−1)` (PTINT eq. 3).
#[inline]
pub fn table_index(t: &[i64; 4]) -> usize {
    let d = |x: i64| (x.signum() + 1) as usize;
    d(t[0]) + 3 * d(t[1]) + 9 * d(t[2]) + 27 * d(t[3])
}

/// The affine-dependency weights `w = (t4, −t3, t2, −t1)`: `Σ w_k (1, v_k) = 0`.
#[inline]
pub fn radon_weights(t: &[i64; 4]) -> [i64; 4] {
    [t[3], -t[2], t[1], -t[0]]
}

/// A sign pattern no four points have (cannot occur with exact tests).
pub const CLASS_IMPOSSIBLE: u8 = 0;
/// All four projected vertices on one line: the tet is flat and is not drawn (PTINT §3.1).
pub const CLASS_COLLINEAR: u8 = 5;

/// One entry of the ternary truth table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Case {
    /// 1 and 2: Wylie's classes; 3 and 4: PTINT's degenerate classes; [`CLASS_COLLINEAR`] and
    /// [`CLASS_IMPOSSIBLE`]: nothing is drawn.
    pub class: u8,
    /// Triangles in the fan (0 when nothing is drawn).
    pub ntri: u8,
    /// Bit masks of the vertex sets A and B (see the module docs); the thick vertex is the
    /// w-weighted mean of either. |A| ≤ |B|.
    pub side_a: u8,
    pub side_b: u8,
    /// The silhouette vertices in fan order around the thick vertex: triangle k is
    /// (thick, fan[k], fan[k + 1]), k < ntri, each with positive orientation
    /// `(b − a) × (c − a) > 0` in pixel coordinates (x right, y down).
    pub fan: [u8; 5],
    /// Per vertex v, the vertex its fan edge is measured from ([`raster::dir_from_thick`]):
    /// derived from the class and sides at compile time ([`Case::with_anchors`]), so that the
    /// rasterisers' set-up reads it instead of choosing it per tet.
    pub anchor: [u8; 4],
}

impl Case {
    const NONE: Case = Case {
        class: CLASS_IMPOSSIBLE,
        ntri: 0,
        side_a: 0,
        side_b: 0,
        fan: [0; 5],
        anchor: [0; 4],
    };

    /// Packs the entry into 32 bits for the GPU: bits 0–3 class, 4–7 ntri, 8–11 side_a,
    /// 12–15 side_b, 16–25 fan[0..5] (2 bits each, fan[k] at bit 16 + 2k).
    pub const fn pack(&self) -> u32 {
        let mut v = (self.class as u32)
            | (self.ntri as u32) << 4
            | (self.side_a as u32) << 8
            | (self.side_b as u32) << 12;
        let mut k = 0;
        while k < 5 {
            v |= (self.fan[k] as u32 & 3) << (16 + 2 * k);
            k += 1;
        }
        v
    }

    /// Inverse of [`Case::pack`].
    pub const fn unpack(v: u32) -> Case {
        let mut fan = [0u8; 5];
        let mut k = 0;
        while k < 5 {
            fan[k] = ((v >> (16 + 2 * k)) & 3) as u8;
            k += 1;
        }
        Case {
            class: (v & 15) as u8,
            ntri: ((v >> 4) & 15) as u8,
            side_a: ((v >> 8) & 15) as u8,
            side_b: ((v >> 12) & 15) as u8,
            fan,
            anchor: [0; 4],
        }
        .with_anchors()
    }

    /// The entry with [`Case::anchor`] derived from its class and sides. The fan edge from
    /// the thick vertex towards v lies on a line through two snapped vertices, so that it is
    /// evaluated exactly: for class 2 the thick vertex is the crossing of sides A and B, and v's
    /// edge runs along v's side, from its other member; otherwise the thick vertex is a snapped
    /// vertex (side A's lowest member, with A and B coinciding in class 4). 0 where there is
    /// none (entries not drawn).
    const fn with_anchors(mut self) -> Case {
        let mut v = 0;
        while v < 4 {
            let set = if self.class != 2 {
                self.side_a
            } else if self.side_a & (1 << v) != 0 {
                self.side_a & !(1 << v)
            } else {
                self.side_b & !(1 << v)
            };
            let a = set.trailing_zeros();
            self.anchor[v] = if a < 4 { a as u8 } else { 0 };
            v += 1;
        }
        self
    }

    /// Whether a tet of this case is drawn.
    #[inline]
    pub const fn drawn(&self) -> bool {
        self.ntri > 0
    }
}

/// The sign (−1, 0, 1) of test `k` (0-based: t1..t4) in table entry `idx`.
const fn test_sign(idx: usize, k: usize) -> i32 {
    let mut d = idx;
    let mut i = 0;
    while i < k {
        d /= 3;
        i += 1;
    }
    (d % 3) as i32 - 1
}

/// Sign of the orientation o(i, j, k) of three distinct vertices in entry `idx`: the test of
/// the sorted triple times the parity of the permutation.
const fn orient_sign(idx: usize, i: usize, j: usize, k: usize) -> i32 {
    let mut v = [i, j, k];
    let mut parity = 1;
    // Bubble sort, counting swaps.
    let mut a = 0;
    while a < 3 {
        let mut b = 0;
        while b + 1 < 3 - a {
            if v[b] > v[b + 1] {
                let t = v[b];
                v[b] = v[b + 1];
                v[b + 1] = t;
                parity = -parity;
            }
            b += 1;
        }
        a += 1;
    }
    // The omitted vertex names the test: (0,1,2)→t1, (0,1,3)→t2, (0,2,3)→t3, (1,2,3)→t4.
    let omitted = 6 - v[0] - v[1] - v[2];
    let test = match omitted {
        3 => 0,
        2 => 1,
        1 => 2,
        _ => 3,
    };
    parity * test_sign(idx, test)
}

/// Builds one entry from its sign pattern alone (see the module docs).
const fn build_case(idx: usize) -> Case {
    // w = (t4, −t3, t2, −t1).
    let w = [
        test_sign(idx, 3),
        -test_sign(idx, 2),
        test_sign(idx, 1),
        -test_sign(idx, 0),
    ];
    let (mut pos, mut neg, mut zero) = (0u8, 0u8, 0u8);
    let (mut npos, mut nneg) = (0, 0);
    let mut k = 0;
    while k < 4 {
        if w[k] > 0 {
            pos |= 1 << k;
            npos += 1;
        } else if w[k] < 0 {
            neg |= 1 << k;
            nneg += 1;
        } else {
            zero |= 1 << k;
        }
        k += 1;
    }
    if npos == 0 && nneg == 0 {
        return Case {
            class: CLASS_COLLINEAR,
            ..Case::NONE
        };
    }
    if npos == 0 || nneg == 0 {
        return Case::NONE;
    }
    let (a, b) = if nneg < npos { (neg, pos) } else { (pos, neg) };
    let av = members(a);
    let bv = members(b);
    let zv = members(zero);
    let mut case = Case {
        class: 0,
        ntri: 0,
        side_a: a,
        side_b: b,
        fan: [0; 5],
        anchor: [0; 4],
    };
    match (av.1, bv.1) {
        (1, 3) => {
            // Class 1: vertex A inside the triangle B.
            let [x, y, z, _] = bv.0;
            let f = if orient_sign(idx, x, y, z) > 0 {
                [x, y, z, x]
            } else {
                [x, z, y, x]
            };
            case.class = 1;
            case.ntri = 3;
            case.fan = [f[0] as u8, f[1] as u8, f[2] as u8, f[3] as u8, 0];
        }
        (2, 2) => {
            // Class 2: edges A = (a0, a1) and B = (b0, b1) cross; the silhouette alternates.
            let [a0, a1, _, _] = av.0;
            let [b0, b1, _, _] = bv.0;
            // Triangle (thick, a0, b0) has the orientation of (a1, a0, b0) = (a0, b0, a1).
            let f = if orient_sign(idx, a0, b0, a1) > 0 {
                [a0, b0, a1, b1, a0]
            } else {
                [a0, b1, a1, b0, a0]
            };
            case.class = 2;
            case.ntri = 4;
            case.fan = [f[0] as u8, f[1] as u8, f[2] as u8, f[3] as u8, f[4] as u8];
        }
        (1, 2) => {
            // Class 3: A lies on the silhouette edge B; the zero vertex is the third corner.
            let [b0, b1, _, _] = bv.0;
            let z = zv.0[0];
            // Triangle (thick, b0, z) has the orientation of (b1, b0, z) = (b0, z, b1).
            let f = if orient_sign(idx, b0, z, b1) > 0 {
                [b0, z, b1]
            } else {
                [b1, z, b0]
            };
            case.class = 3;
            case.ntri = 2;
            case.fan = [f[0] as u8, f[1] as u8, f[2] as u8, 0, 0];
        }
        _ => {
            // Class 4: A and B coincide; the silhouette is (thick, z0, z1).
            let a0 = av.0[0];
            let [z0, z1, _, _] = zv.0;
            let f = if orient_sign(idx, a0, z0, z1) > 0 {
                [z0, z1]
            } else {
                [z1, z0]
            };
            case.class = 4;
            case.ntri = 1;
            case.fan = [f[0] as u8, f[1] as u8, 0, 0, 0];
        }
    }
    case
}

/// The members of a 4-bit mask in increasing order, and their count.
const fn members(mask: u8) -> ([usize; 4], usize) {
    let mut out = [0usize; 4];
    let mut n = 0;
    let mut k = 0;
    while k < 4 {
        if mask & (1 << k) != 0 {
            out[n] = k;
            n += 1;
        }
        k += 1;
    }
    (out, n)
}

const fn build_table() -> [Case; 81] {
    let mut t = [Case::NONE; 81];
    let mut i = 0;
    while i < 81 {
        t[i] = build_case(i).with_anchors();
        i += 1;
    }
    t
}

/// The ternary truth table, indexed by [`table_index`]; built at compile time from the sign
/// patterns by [`build_case`]: 8 class-1, 6 class-2 (Wylie's 14), 24 class-3, 12 class-4 entries,
/// 1 collinear entry and 30 impossible ones.
pub static TABLE: [Case; 81] = build_table();

/// The table as WGSL: `const PT_TABLE: array<u32, 81>` of [`Case::pack`]ed entries, with the
/// layout in a comment, for the GPU renderers.
pub fn table_wgsl() -> String {
    let mut s = String::from(
        "// Projected-tetrahedra ternary truth table, generated by algorithms::render::pt::table_wgsl().\n\
         // Index: sum over the tests t1..t4 of PTINT Fig. 3 of (sign(t_i) + 1) * 3^(i-1).\n\
         // Entry bits: 0-3 class (0 impossible, 1-4, 5 collinear), 4-7 triangles in the fan,\n\
         // 8-11 set A mask, 12-15 set B mask, 16+2k fan vertex k (k < 5).\n",
    );
    s.push_str(&format!(
        "const PT_SUBPIXEL_BITS: u32 = {SUBPIXEL_BITS}u;\nconst PT_TABLE: array<u32, 81> = array<u32, 81>(\n"
    ));
    for (i, c) in TABLE.iter().enumerate() {
        s.push_str(&format!("    0x{:08x}u,", c.pack()));
        s.push_str(if i % 6 == 5 || i == 80 { "\n" } else { "" });
    }
    s.push_str(");\n");
    s
}

/// One projected vertex, as classification needs it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjVertex {
    /// Snapped pixel coordinates ([`snap`]).
    pub q: [i64; 2],
    /// Depth along the view axis ([`crate::camera::Camera::project`]).
    pub z: f64,
    /// Position in the centred frame.
    pub p: DVec3,
    /// Transfer-function coordinate.
    pub s: f64,
}

impl ProjVertex {
    /// The vertex at `p` (centred frame) with TF coordinate `s`, projected by `cam` and
    /// snapped ([`snap`]).
    pub fn project(cam: &crate::camera::Camera, p: DVec3, s: f64) -> ProjVertex {
        let (x, y, z) = cam.project(p);
        ProjVertex {
            q: [snap(x), snap(y)],
            z,
            p,
            s,
        }
    }
}

/// A classified tet: the table entry and the thick vertex.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Thick {
    /// Index into [`TABLE`].
    pub case: u8,
    /// Thick vertex in snapped units (not on the grid for class 2).
    pub x: f64,
    pub y: f64,
    /// Front and back scalars and depths along the view axis of the thick ray's segment.
    pub sf: f64,
    pub sb: f64,
    pub zf: f64,
    pub zb: f64,
    /// Thickness in optical units (world length / L, CONVENTIONS §1).
    pub l: f64,
}

impl Thick {
    #[inline]
    pub fn entry(&self) -> &'static Case {
        &TABLE[self.case as usize]
    }
}

/// The point of the hull of `set` on the thick ray: 2-D weights `λ_k = w_k / Σ w_k` (exact
/// integers, all of one sign); in perspective the 3-D weights are `μ_k ∝ λ_k / z_k`
/// (perspective-correct interpolation: 1/z is linear in screen space). Returns (position,
/// scalar, depth).
#[inline]
fn hull_point(v: &[ProjVertex; 4], w: &[i64; 4], set: u8, persp: bool) -> (DVec3, f64, f64) {
    let mut sum = 0.0;
    for (k, &wk) in w.iter().enumerate() {
        if set & (1 << k) != 0 {
            sum += wk as f64;
        }
    }
    let (mut p, mut s, mut acc) = (DVec3::ZERO, 0.0, 0.0);
    let mut zl = 0.0;
    for k in 0..4 {
        if set & (1 << k) == 0 {
            continue;
        }
        let lam = w[k] as f64 / sum;
        let mu = if persp { lam / v[k].z } else { lam };
        p += mu * v[k].p;
        s += mu * v[k].s;
        acc += mu;
        zl += lam * v[k].z;
    }
    if persp {
        // Σ λ_k/z_k = 1/z of the point.
        (p / acc, s / acc, 1.0 / acc)
    } else {
        (p, s, zl)
    }
}

/// Classifies one tet from its projected vertices: the table entry and, for a drawn tet, the
/// thick vertex with `s_f`, `s_b`, the depths and `l = |X_B − X_A| / L` (`inv_l = 1/L`).
#[inline]
pub fn classify(v: &[ProjVertex; 4], persp: bool, inv_l: f64) -> Thick {
    let q = [v[0].q, v[1].q, v[2].q, v[3].q];
    let t = tests(&q);
    let idx = table_index(&t);
    let c = &TABLE[idx];
    let mut out = Thick {
        case: idx as u8,
        ..Default::default()
    };
    if !c.drawn() {
        return out;
    }
    let w = radon_weights(&t);
    // The thick vertex in 2-D: Σ_A w_k q_k / Σ_A w_k (a vertex unless class 2).
    if c.class == 2 {
        let (mut x, mut y, mut sum) = (0.0, 0.0, 0.0);
        for k in 0..4 {
            if c.side_a & (1 << k) != 0 {
                x += w[k] as f64 * q[k][0] as f64;
                y += w[k] as f64 * q[k][1] as f64;
                sum += w[k] as f64;
            }
        }
        out.x = x / sum;
        out.y = y / sum;
    } else {
        let a = c.side_a.trailing_zeros() as usize;
        out.x = q[a][0] as f64;
        out.y = q[a][1] as f64;
    }
    let (pa, sa, za) = hull_point(v, &w, c.side_a, persp);
    let (pb, sb, zb) = hull_point(v, &w, c.side_b, persp);
    out.l = (pb - pa).length() * inv_l;
    if za <= zb {
        (out.sf, out.sb, out.zf, out.zb) = (sa, sb, za, zb);
    } else {
        (out.sf, out.sb, out.zf, out.zb) = (sb, sa, zb, za);
    }
    out
}

/// [`classify`] in an orthographic view, for what `cpu-pt`'s fast path keeps of it: the table
/// index and, for a drawn tet, `[s_f, s_b, l]` (else zeros), with `classify`'s bits (test:
/// `classify_ortho_is_classify`). From the vertices' snapped coordinates `q`, depths `z`,
/// centred positions `p` and TF coordinates `s`.
///
/// What it leaves out is what the fast path does not read (the thick vertex's screen position,
/// the depths); and the hull points are sums over all four vertices with the weights of the
/// set's non-members zero instead of loops over the members: adding `0·x` (x finite) to a sum
/// leaves it as it was, so the sums are `hull_point`'s, without a branch per vertex.
#[inline(always)]
pub fn classify_ortho(
    q: &[[i64; 2]; 4],
    z: &[f64; 4],
    p: &[DVec3; 4],
    s: &[f64; 4],
    inv_l: f64,
) -> (u8, [f64; 3]) {
    let t = tests(q);
    let idx = table_index(&t);
    let c = &TABLE[idx];
    if !c.drawn() {
        return (idx as u8, [0.0; 3]);
    }
    let w = radon_weights(&t);
    // The hull point of a set: λ_k = w_k / Σ_set w (0 off the set); position, scalar, depth.
    let hull = |set: u8| {
        let wk: [f64; 4] = std::array::from_fn(|k| {
            if set & (1 << k) != 0 {
                w[k] as f64
            } else {
                0.0
            }
        });
        let sum = ((0.0 + wk[0]) + wk[1]) + wk[2] + wk[3];
        let (mut pp, mut ss, mut zz) = (DVec3::ZERO, 0.0, 0.0);
        for k in 0..4 {
            let lam = wk[k] / sum;
            pp += lam * p[k];
            ss += lam * s[k];
            zz += lam * z[k];
        }
        (pp, ss, zz)
    };
    let ((pa, sa, za), (pb, sb, zb)) = (hull(c.side_a), hull(c.side_b));
    let l = (pb - pa).length() * inv_l;
    let (sf, sb) = if za <= zb { (sa, sb) } else { (sb, sa) };
    (idx as u8, [sf, sb, l])
}

#[cfg(test)]
pub(crate) mod tests;
