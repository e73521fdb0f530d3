//! The fast path of `cpu-pt`'s draw stage: orthographic views with an f32 integrator
//! ([`FastIntegrator`]: `average`, `partial`, `preint`), which is what the speed tables run.
//!
//! What makes it fast, against the general path in `general.rs` (which stays the definition for
//! perspective and the f64 integrators, and which `cpu_pt`'s tests compare this one with):
//! - **one record per tet, one cache line** ([`FastRec`], 64 B): the snapped vertices, their
//!   transfer-function coordinates and the thick vertex's `s_f`, `s_b`, `l`, written by the
//!   project stage at the tet's place in the visibility order, so that drawing a tet is one
//!   access at a growing address instead of six at random (tet, record, four vertices);
//! - **the whole tet at once** ([`TetRaster`]): one set of exact integer edge functions per
//!   tet (silhouette edges and the fan edges from the thick vertex, each shared by the two fan
//!   triangles it separates) and the exact span of each silhouette row;
//! - **spans, not pixels** ([`Kernel::Spans`]): every centre of a row's span is in the fan, and
//!   its attributes are the min or max of the fan triangles' planes (see [`spans`] for why), so
//!   a row is evaluated a vector of pixels at a time, in f32, with no per-pixel choice of
//!   triangle; the per-pixel kernel (the fan triangle from the fan edges' signs, its f64 plane)
//!   stays for tets with a degenerate fan triangle and as the definition the spans are tested
//!   against (`span_kernel_matches_per_pixel_kernel`);
//! - **few-centre tets alone** ([`SmallTet`], [`small`]): a tet whose pixel box in the tile holds
//!   at most [`SMALL_CENTRES`] centres (on `post` at 512², most of them) skips the rows' set-up;
//!   each centre is tested against the fan and silhouette edges and takes its triangle's plane,
//!   as the per-pixel kernel does (the same fragments; values to f32 rounding of the spans'),
//!   and a box with no centre in the tet's hull is skipped first
//!   ([`hull_misses_centres_in`](crate::render::pt::hull_misses_centres_in));
//! - **batched shading** ([`Queue`]): fragments are queued, a batch is shaded at once and then
//!   composited in queue order, which is the order a per-fragment loop would composite in, so
//!   the image is the same; `partial` queues colours, taken from the tet's line of the transfer
//!   function where its scalars lie on one piece (or its two lines where they cross one control
//!   point: [`TfSpan`]), so that its batch kernel has no table look-up.
//!
//! The draw of a tile is compiled for the best instruction set of the CPU (`pulp`'s run-time
//! dispatch; x86-64-v3 where present), with a scalar fallback.

use super::queue::{Lanes, Queue};
use super::TILE;
use crate::util::prefetch;
use crate::optics::fast::{FastIntegrator, TfSpan};
use crate::render::pt::{
    fan_bits, hull_misses_centres_in, pixel_box_i32, wedge, Case, Fit, SmallTet, TetRaster, MAX_FAN, TABLE,
};

/// What drawing one tet needs, in one 64-byte line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(super) struct FastRec {
    /// Snapped pixel coordinates of the four vertices.
    pub q: [[i32; 2]; 4],
    /// Transfer-function coordinate of the four vertices.
    pub s: [f32; 4],
    /// The thick vertex's front and back scalars and thickness (optical units).
    pub sf: f32,
    pub sb: f32,
    pub l: f32,
    /// Index into [`TABLE`].
    pub case: u8,
}

/// Renders tile (tx, ty) of a `w`×`h` image from its tets (`items`, places in `recs`, back to
/// front) over what `buf` (the tile's RGBA rows, TILE wide) holds; returns the fragment count.
/// Compiled for the best instruction set of the CPU (`pulp`'s run-time dispatch), so that the
/// span kernel runs 8 lanes wide.
// Never inlined, so that a profile (callgrind's `--toggle-collect='*draw_tile*'`) finds the
// draw under any inlining decision of the caller.
#[inline(never)]
pub(super) fn draw_tile(
    recs: &[FastRec],
    items: &[u32],
    integ: &FastIntegrator,
    tile: (u32, u32),
    size: (u32, u32),
    buf: &mut [[f32; 4]],
) -> u64 {
    pulp::Arch::new().dispatch(DrawTile {
        recs,
        items,
        integ,
        tile,
        size,
        kernel: Kernel::Spans,
        buf,
    })
}

/// How `draw_tile` finds each fragment's attributes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Kernel {
    /// Per row, every attribute as the min or max of the fan triangles' planes, a vector of pixels
    /// at a time ([`spans`]); tets with a degenerate fan triangle go per pixel.
    Spans,
    /// Per pixel, the fan triangle from the fan edges' signs and its plane (the definition the
    /// spans are tested against).
    #[cfg_attr(not(test), allow(dead_code))]
    PerPixel,
}

pub(super) struct DrawTile<'a> {
    pub(super) recs: &'a [FastRec],
    pub(super) items: &'a [u32],
    pub(super) integ: &'a FastIntegrator,
    pub(super) tile: (u32, u32),
    pub(super) size: (u32, u32),
    pub(super) kernel: Kernel,
    /// The tile's buffer, composited onto.
    pub(super) buf: &'a mut [[f32; 4]],
}

impl pulp::WithSimd for DrawTile<'_> {
    type Output = u64;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> Self::Output {
        self.run(simd)
    }
}

impl DrawTile<'_> {
    #[inline(always)]
    fn run<S: pulp::Simd>(self, simd: S) -> u64 {
        let (recs, items, integ) = (self.recs, self.items, self.integ);
        let buf = self.buf;
        let clip = super::bins::tile_clip(self.tile.0, self.tile.1, self.size.0, self.size.1);
        let (x0, y0) = (clip[0], clip[1]);
        let mut qu = Queue::new(integ);
        let mut sm = SmallTet::default();
        for (n, &t) in items.iter().enumerate() {
            // A tile's records are read at growing but sparse addresses, which the hardware's
            // prefetcher does not follow (1.16× the draw without this): ask a few tets ahead.
            if let Some(&ahead) = items.get(n + PREFETCH) {
                prefetch(&recs[ahead as usize]);
            }
            let r = &recs[t as usize];
            let case = &TABLE[r.case as usize];
            let q = r.q.map(|v| [v[0] as i64, v[1] as i64]);
            // The tet's pixel box in the tile, once, in vectors.
            let b = pixel_box_i32(simd, &r.q);
            let bx = [b[0].max(clip[0]), b[1].max(clip[1]), b[2].min(clip[2]), b[3].min(clip[3])];
            if bx[0] > bx[2] || bx[1] > bx[3] {
                continue;
            }
            if self.kernel == Kernel::Spans {
                // A tet of a few centres with none of them in its hull in this tile draws
                // nothing: skipped before any set-up (on post at 512², 89 844 of 197 947
                // few-centre tets). (The tet's whole box must be small, not only its part in
                // the tile: the test's integers are exact for so small a tet only.)
                let few = (b[2] - b[0] + 1) * (b[3] - b[1] + 1) <= SMALL_CENTRES;
                if few && hull_misses_centres_in(simd, &r.q, bx) {
                    continue;
                }
                match sm.set_up_in(case, &q, bx, SMALL_CENTRES) {
                    Fit::Empty => continue,
                    Fit::Small => {
                        let span = qu.span(&r.s);
                        small(&sm, r, case, (x0, y0), span, &mut qu, buf);
                        continue;
                    }
                    Fit::Large => {}
                }
            }
            let Some(mut tr) = TetRaster::new_in(case, &q, bx) else {
                continue;
            };
            let span = qu.span(&r.s);
            if self.kernel == Kernel::Spans && tr.valid == (1 << tr.ntri) - 1 {
                spans(simd, &mut tr, r, case, (x0, y0), span, &mut qu, buf);
            } else {
                let planes = Planes::new(&tr, r, case);
                per_pixel(&mut tr, &planes, (x0, y0), span, &mut qu, buf);
            }
        }
        qu.flush(buf);
        qu.frags
    }
}

/// The attribute planes of one tet's fan triangles (`[triangle][channel]`, channels `s_f`,
/// `s_b`, `l`): `thick + F_{k+1}·cx + F_k·cy`, `da` per pixel along a row.
struct Planes {
    thick: [f64; 3],
    cx: [[f64; 4]; 4],
    cy: [[f64; 4]; 4],
    da: [[f64; 4]; 4],
}

impl Planes {
    /// Attributes (s_f, s_b, l) over fan triangle k: thick + lx·(x − thick) + ly·(y − thick)
    /// with x, y its silhouette vertices (l = 0 there) and lx = −F_{k+1}·inv_x,
    /// ly = F_k·inv_y (see `TetRaster`): thick + F_{k+1}·cx[k] + F_k·cy[k], in f64, set up
    /// once per tet; `da` is the step per pixel. ([`SpanSet::new`] computes the same planes,
    /// operation for operation, for the span kernel.)
    #[inline(always)]
    fn new(tr: &TetRaster, r: &FastRec, case: &Case) -> Planes {
        let thick = [r.sf as f64, r.sb as f64, r.l as f64];
        let mut cx = [[0.0f64; 4]; 4];
        let mut cy = [[0.0f64; 4]; 4];
        let mut da = [[0.0f64; 4]; 4];
        for k in 0..tr.ntri {
            let sx = r.s[case.fan[k] as usize] as f64;
            let sy = r.s[case.fan[k + 1] as usize] as f64;
            let dx = [sx - thick[0], sx - thick[1], -thick[2]];
            let dy = [sy - thick[0], sy - thick[1], -thick[2]];
            for ch in 0..3 {
                cx[k][ch] = -tr.inv_x[k] * dx[ch];
                cy[k][ch] = tr.inv_y[k] * dy[ch];
                da[k][ch] = tr.gst[k + 1] as f64 * cx[k][ch] + tr.gst[k] as f64 * cy[k][ch];
            }
        }
        Planes { thick, cx, cy, da }
    }

    /// Channel `ch` of triangle `k`'s plane at a pixel whose unbiased fan edges are `f`.
    #[inline(always)]
    fn at(&self, f: &[f64; MAX_FAN], k: usize, ch: usize) -> f64 {
        self.thick[ch] + f[k + 1] * self.cx[k][ch] + f[k] * self.cy[k][ch]
    }
}

/// The span kernel: every row of the silhouette at once, its attributes as the min or max of
/// the fan triangles' planes.
///
/// Why that is the fan's interpolation: over the snapped tet, `l` is the thickness of a convex
/// solid along the ray, `z_out − z_in` with `z_in` the max of the front faces' depths and
/// `z_out` the min of the back faces' (both linear per face), so `l` is concave and, being
/// linear over each fan triangle, the min of the triangles' planes. The scalar is linear in the
/// tet, `s = S(x, y) + σ·z`, so `s_f = S + σ·z_in` is convex when σ ≥ 0 (the max of the planes)
/// and concave when σ < 0 (the min), and `s_b = S + σ·z_out` the other way round; σ has the sign
/// of `s_b − s_f` at the thick vertex (see [`SpanSet::new`]). On each triangle its own plane
/// attains the min (max), so the value is its plane's, up to rounding: the planes are evaluated
/// in f32 (`base + k·step`, k < 128, the tile's width) where the per-pixel kernel rounds its f64
/// value once.
///
/// Every centre of a row is in the fan when all its triangles are valid (they tile the
/// silhouette), which the caller checks; the queue takes the whole row.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn spans<S: pulp::Simd>(
    simd: S,
    tr: &mut TetRaster,
    r: &FastRec,
    case: &Case,
    tile: (i64, i64),
    span: Option<TfSpan>,
    qu: &mut Queue,
    buf: &mut [[f32; 4]],
) {
    let set = SpanSet::new(simd, tr, r, case, tile);
    // The rows with as many planes a channel as the fan has triangles: a class-1 fan (three)
    // evaluates 9 planes a vector, not 12 (until 27efeca the missing triangles repeated
    // triangle 0, which changed no min or max: the same bits).
    match tr.ntri {
        1 => span_rows::<S, 1>(simd, tr, &set, span, qu, buf),
        2 => span_rows::<S, 2>(simd, tr, &set, span, qu, buf),
        3 => span_rows::<S, 3>(simd, tr, &set, span, qu, buf),
        _ => span_rows::<S, 4>(simd, tr, &set, span, qu, buf),
    }
}

/// One tet's planes as [`spans`] sets them up (index `ch·4 + k`: channel ch, triangle k): their
/// value at centre `origin` in f64, steps per row and per column (f64), and per column as f32
/// vectors; `sgv` the sign of the `s_f`, `s_b` channels; `tile` the tile's first centre.
struct SpanSet<V> {
    v0: [f64; 12],
    dy: [f64; 12],
    dx: [f64; 12],
    stepv: [V; 12],
    sgv: V,
    origin: (i64, i64),
    tile: (i64, i64),
}

impl<V: Copy> SpanSet<V> {
    /// The planes of [`Planes::new`] and [`Planes::at`], computed the same way (the same
    /// operations in the same order, so the same bits) but straight into the span kernel's
    /// layout, for all four triangle slots at once (in f64 vectors; the slots past `ntri` have
    /// zero normalisers and are never read), and each times its channel's sign: max for `s_f`,
    /// min for `s_b` when σ ≥ 0 (`s_b ≥ s_f` at the thick vertex); with σ < 0 both negated
    /// (exactly), so that one kernel serves both. Per plane (index `ch·4 + k`): its value at
    /// centre (ia, j0), its steps per row and per column; the row's start is then a product and
    /// a sum twice a plane, in f64 vectors, not the plane's evaluation from the fan edges.
    /// (Negating before the rounding to f32 gives the bits of negating after it.)
    #[inline(always)]
    fn new<S: pulp::Simd<f32s = V>>(
        simd: S,
        tr: &TetRaster,
        r: &FastRec,
        case: &Case,
        tile: (i64, i64),
    ) -> SpanSet<V> {
        let thick = [r.sf as f64, r.sb as f64, r.l as f64];
        let sg = if r.sb >= r.sf { 1.0f32 } else { -1.0 };
        let sign = [sg as f64, sg as f64, 1.0];
        let sx: [f64; 4] = std::array::from_fn(|t| r.s[case.fan[t] as usize] as f64);
        let sy: [f64; 4] = std::array::from_fn(|t| r.s[case.fan[t + 1] as usize] as f64);
        let fe: [f64; MAX_FAN] = std::array::from_fn(|m| (tr.g[m] - tr.gbias[m]) as f64);
        let gst: [f64; MAX_FAN] = std::array::from_fn(|m| tr.gst[m] as f64);
        let gsr: [f64; MAX_FAN] = std::array::from_fn(|m| tr.gsr[m] as f64);
        // Per triangle slot t: the fan edges F_{t+1} and F_t (value, steps), as arrays of four.
        let four = |a: &[f64; MAX_FAN], o: usize| -> [f64; 4] { std::array::from_fn(|t| a[t + o]) };
        let (f1, f0) = (four(&fe, 1), four(&fe, 0));
        let (gst1, gst0, gsr1, gsr0) = (four(&gst, 1), four(&gst, 0), four(&gsr, 1), four(&gsr, 0));
        let nix: [f64; 4] = std::array::from_fn(|t| -tr.inv_x[t]);
        let (mut v0, mut dy, mut dx) = ([0.0f64; 12], [0.0f64; 12], [0.0f64; 12]);
        for ch in 0..3 {
            let (ex, ey): ([f64; 4], [f64; 4]) = if ch < 2 {
                (sx.map(|v| v - thick[ch]), sy.map(|v| v - thick[ch]))
            } else {
                ([-thick[2]; 4], [-thick[2]; 4])
            };
            // The four slots in `simd`'s f64 vectors (one with AVX2); each product and sum
            // rounded as the scalar expression's (a loop over the slots with the three results
            // interleaved was left scalar: ~200 instructions a tet).
            let (thv, sgn) = (simd.splat_f64s(thick[ch]), simd.splat_f64s(sign[ch]));
            let v = |a| S::as_simd_f64s(a).0;
            let (nixv, iyv, exv, eyv) = (v(&nix), v(&tr.inv_y), v(&ex), v(&ey));
            let (f1v, f0v, gs1v, gs0v) = (v(&f1), v(&f0), v(&gst1), v(&gst0));
            let (gr1v, gr0v) = (v(&gsr1), v(&gsr0));
            let range = ch * 4..ch * 4 + 4;
            let vo = S::as_mut_simd_f64s(&mut v0[range.clone()]).0;
            let ro = S::as_mut_simd_f64s(&mut dy[range.clone()]).0;
            let co = S::as_mut_simd_f64s(&mut dx[range]).0;
            for i in 0..vo.len() {
                let cx = simd.mul_f64s(nixv[i], exv[i]);
                let cy = simd.mul_f64s(iyv[i], eyv[i]);
                // (thick + F_{t+1}·cx) + F_t·cy, then the sign; the steps likewise.
                let at = simd.add_f64s(thv, simd.mul_f64s(f1v[i], cx));
                let at = simd.add_f64s(at, simd.mul_f64s(f0v[i], cy));
                vo[i] = simd.mul_f64s(at, sgn);
                let row = simd.add_f64s(simd.mul_f64s(gr1v[i], cx), simd.mul_f64s(gr0v[i], cy));
                ro[i] = simd.mul_f64s(row, sgn);
                let col = simd.add_f64s(simd.mul_f64s(gs1v[i], cx), simd.mul_f64s(gs0v[i], cy));
                co[i] = simd.mul_f64s(col, sgn);
            }
        }
        // Splats in plain loops, not `array::map`: a closure does not inherit the target
        // features of the function it sits in, and when the compiler leaves it out of line (as
        // it did with 16 codegen units after an unrelated change) every splat became a call and
        // the draw ran 1.48× slower.
        let mut stepv = [simd.splat_f32s(0.0); 12];
        for (v, &d) in stepv.iter_mut().zip(&dx) {
            *v = simd.splat_f32s(d as f32);
        }
        SpanSet {
            v0,
            dy,
            dx,
            stepv,
            sgv: simd.splat_f32s(sg),
            origin: (tr.ia, tr.j0),
            tile,
        }
    }
}

/// The rows of [`spans`] with the first `NT` triangles' planes of each channel.
#[inline(always)]
fn span_rows<S: pulp::Simd, const NT: usize>(
    simd: S,
    tr: &mut TetRaster,
    set: &SpanSet<S::f32s>,
    span: Option<TfSpan>,
    qu: &mut Queue,
    buf: &mut [[f32; 4]],
) {
    let ts = TILE as usize;
    let ((ia, j0), (x0, y0)) = (set.origin, set.tile);
    let stepv = &set.stepv;
    // f32 lanes per vector (8 with AVX2; 1 on the scalar fallback).
    let lanes = S::F32_LANES.min(IOTA.len());
    // The lane offsets 0, 1, …: one whole-vector load (`partial_load` is pulp's masked-load
    // call even for a full vector).
    let iota = S::as_simd_f32s(&IOTA[..lanes]).0[0];
    while let Some((j, i0, i1)) = tr.next_span(simd) {
        let n = (i1 - i0 + 1) as usize;
        let (r, a) = ((j - j0) as f64, (i0 - ia) as f64);
        let mut b64 = [0.0f64; 12];
        {
            let (rv, av) = (simd.splat_f64s(r), simd.splat_f64s(a));
            let ((v0v, v0t), (dyv, dyt), (dxv, dxt)) = (
                S::as_simd_f64s(&set.v0),
                S::as_simd_f64s(&set.dy),
                S::as_simd_f64s(&set.dx),
            );
            let (bv, bt) = S::as_mut_simd_f64s(&mut b64);
            for (((b, &v), &y), &x) in bv.iter_mut().zip(v0v).zip(dyv).zip(dxv) {
                // (v0 + r·dy) + a·dx, each operation rounded as the scalar expression.
                *b = simd.add_f64s(simd.add_f64s(v, simd.mul_f64s(rv, y)), simd.mul_f64s(av, x));
            }
            for (((b, &v), &y), &x) in bt.iter_mut().zip(v0t).zip(dyt).zip(dxt) {
                *b = v + r * y + a * x;
            }
        }
        qu.reserve(n.div_ceil(lanes) * lanes, buf);
        let p0 = ((j - y0) as usize * ts + (i0 - x0) as usize) as u16;
        // Rounded to f32 all twelve at once (three vector conversions with AVX2), then each
        // broadcast from memory: one scalar conversion and one broadcast a plane were 2 % of
        // a post draw's instructions.
        let mut b32 = [0.0f32; 12];
        for (d, &b) in b32.iter_mut().zip(&b64) {
            *d = b as f32;
        }
        for c in 0..n.div_ceil(lanes) {
            // Each plane's base broadcast from `b32` where it is used, a vector at a time: the
            // compiler hoisted the twelve broadcasts out of this loop (a row is 1.24 vectors on
            // post), and with the twelve steps they outnumbered AVX2's sixteen registers, so
            // each row stored them to the stack and each vector loaded them back. `black_box`
            // keeps them here (post's draw 1 355.7 M → 1 306.9 M instructions, the same bits).
            let b32 = std::hint::black_box(&b32);
            // (Through i32, below the tile's width: `usize as f32` tests the sign first.)
            let x = simd.add_f32s(iota, simd.splat_f32s((c * lanes) as i32 as f32));
            let plane = |ch: usize, k: usize| {
                simd.mul_add_f32s(x, stepv[ch * 4 + k], simd.splat_f32s(b32[ch * 4 + k]))
            };
            let (mut vf, mut vb, mut vl) = (plane(0, 0), plane(1, 0), plane(2, 0));
            for k in 1..NT {
                vf = simd.max_f32s(vf, plane(0, k));
                vb = simd.min_f32s(vb, plane(1, k));
                vl = simd.min_f32s(vl, plane(2, k));
            }
            let v = Lanes {
                sf: simd.mul_f32s(vf, set.sgv),
                sb: simd.mul_f32s(vb, set.sgv),
                l: vl,
                count: (n - c * lanes).min(lanes),
            };
            qu.push_lanes(simd, span, v, p0.wrapping_add((c * lanes) as u16));
        }
    }
}

/// Lane offsets 0, 1, 2, … (for the widest f32 vector there is).
const IOTA: [f32; 16] = [
    0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 15.0,
];

/// The per-pixel kernel: each centre's fan triangle from the fan edges' signs ([`wedge`]) and
/// its plane, rounded from f64 once.
#[inline(always)]
fn per_pixel(
    tr: &mut TetRaster,
    pl: &Planes,
    (x0, y0): (i64, i64),
    span: Option<TfSpan>,
    qu: &mut Queue,
    buf: &mut [[f32; 4]],
) {
    let ts = TILE as usize;
    let (gbias, gst, valid, ntri) = (tr.gbias, tr.gst, tr.valid, tr.ntri);
    while let Some(row) = tr.next_row() {
        let n = (row.i1 - row.i0 + 1) as usize;
        // The attributes at the row's first pixel, per triangle.
        let f: [f64; MAX_FAN] = std::array::from_fn(|m| (row.g[m] - gbias[m]) as f64);
        let mut base = [[0.0f64; 4]; 4];
        for (k, b) in base.iter_mut().enumerate().take(ntri) {
            for (ch, v) in b.iter_mut().enumerate().take(3) {
                *v = pl.at(&f, k, ch);
            }
        }
        let p0 = ((row.j - y0) as usize * ts + (row.i0 - x0) as usize) as u16;
        let mut g = row.g;
        // Every pixel of the row is written to the queue; the queue advances only where it
        // is in one of the fan's triangles (no branch: the rows are a few pixels long).
        for kk in 0..n {
            let t = wedge(fan_bits(&g), valid);
            let tri = (t.trailing_zeros() & 3) as usize;
            let kf = kk as f64;
            let (b, d) = (&base[tri], &pl.da[tri]);
            qu.reserve(1, buf);
            qu.push(
                span,
                (b[0] + kf * d[0]) as f32,
                (b[1] + kf * d[1]) as f32,
                (b[2] + kf * d[2]) as f32,
                p0 + kk as u16,
            );
            qu.advance((t != 0) as usize);
            for (v, s) in g.iter_mut().zip(&gst) {
                *v += s;
            }
        }
    }
}

/// The kernel of the few-centre tets ([`SmallTet`]): each centre of the box is queued, and the
/// queue advances where the centre is in a fan triangle (no branch per centre); its attributes
/// are that triangle's plane, in f64, rounded once (as the per-pixel kernel's).
#[inline(always)]
fn small(
    sm: &SmallTet,
    r: &FastRec,
    case: &Case,
    (x0, y0): (i64, i64),
    span: Option<TfSpan>,
    qu: &mut Queue,
    buf: &mut [[f32; 4]],
) {
    let ts = TILE as usize;
    let thick = [r.sf as f64, r.sb as f64, r.l as f64];
    for dj in 0..sm.h {
        let row = (sm.ja + dj - y0) as usize * ts;
        for di in 0..sm.w {
            let (hit, f) = sm.centre(di, dj);
            let k = (hit.trailing_zeros() & 3) as usize;
            let sx = r.s[case.fan[k] as usize] as f64;
            let sy = r.s[case.fan[k + 1] as usize] as f64;
            let (fx, fy) = (f[k + 1] as f64, f[k] as f64);
            let (ix, iy) = (-sm.inv_x[k], sm.inv_y[k]);
            // thick + F_{k+1}·cx + F_k·cy, cx = −inv_x·(s_x − thick), cy = inv_y·(s_y − thick)
            // (`Planes::at`).
            let at = |ch: usize, dx: f64, dy: f64| thick[ch] + fx * (ix * dx) + fy * (iy * dy);
            let sf = at(0, sx - thick[0], sy - thick[0]);
            let sb = at(1, sx - thick[1], sy - thick[1]);
            let l = at(2, -thick[2], -thick[2]);
            qu.reserve(1, buf);
            let p = (row + (sm.ia + di - x0) as usize) as u16;
            qu.push(span, sf as f32, sb as f32, l as f32, p);
            qu.advance((hit != 0) as usize);
        }
    }
}

/// The most centres a tet's pixel box may hold for [`small`] to draw it (boxes of up to 1, 2, 4,
/// 8 and 16 centres: post's draw 0.886, 0.859, 0.850, 0.851, 0.891 of the rows' for all, in one
/// interleaved run).
const SMALL_CENTRES: i64 = 4;

/// How many tets ahead `draw_tile` prefetches.
const PREFETCH: usize = 8;
