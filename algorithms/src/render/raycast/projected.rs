//! The projected walk: the cell walk of `raycast` with every integrator, `exact` (`reference`)
//! included; the reference walk of `walk.rs` is kept as the one the tests hold it to.
//!
//! The ray is the origin of a 2-D frame `(f1, f2)` perpendicular to it (`f1 × f2 = d̂`), and
//! each vertex of a cell is transformed into that frame once, when the walk first meets it
//! (the three vertices of the face it came through carry theirs). The Plücker product of the
//! ray with a directed edge `a → b` is then the 2-D cross product `a.x·b.y − a.y·b.x`
//! (Binet–Cauchy: `(a × b)·(f1 × f2)`), two products instead of orient3d's nine. The rays of an
//! orthographic view share one frame ([`SharedFrame`]): every vertex is put in its axes once per
//! image, and a step subtracts the ray's origin there instead of taking three dot products.
//!
//! **Decisions are the exact ones.** A product is accepted when its magnitude exceeds a static
//! per-ray bound of its rounding error *against the exact orient3d* of the three-dimensional
//! vertices ([`Frame2::new`]); below the bound the walk asks the exact predicate of
//! [`Prepared::edge`] (Shewchuk's orient3d with the Simulation-of-Simplicity tie rule), counted
//! in `filter_fallbacks`. So every sign is the sign the `reference` walk decides for the same
//! edge, neighbouring cells agree on every shared edge, and the walk is watertight for the same
//! reason the reference is.
//!
//! **The exit face from the apex.** The ray enters a cell through triangle `(A, B, C)` whose
//! directed edge products `A→B, B→C, C→A` all have one sign `w` (the entry's winding as the
//! ray sees it); `D` is the cell's fourth vertex. The ray leaves through the face `X Y D`
//! (`X → Y` an edge of the entry face in that order) whose other edges `Y → D` and `D → X` have
//! the sign `w` too: with `b_V` = "`V → D` has sign `w`", through `ABD` iff `b_B ∧ ¬b_A`, `BCD`
//! iff `b_C ∧ ¬b_B`, `CAD` iff `b_A ∧ ¬b_C` — exactly one of them for consistent signs. The new
//! entry triangle is `(X, Y, D)`, of winding `w` again, so no orientation of the cell and no
//! face-vertex matching is needed: only the local index of the dropped vertex, for the link.
//! The walk keeps the triangle in three slots and writes `D` into the dropped vertex's slot:
//! the slots in order are then `(X, Y, D)` rotated, the same circulation, and nothing moves.
//!
//! **The crossing** is interpolated with the barycentric weights `|Y→D|, |D→X|, |X→Y|` (the last
//! carried) of the per-vertex depth along the ray and scalar. A step only queues the weights and
//! the three vertices' depths and scalars; the normalisation (a division), the blend, the
//! segment's length and the TF are computed for a queue at a time ([`drain`]), lane-wise where
//! they can be, so that a step's chain of dependent operations ends at its exit face: the
//! out-of-order window holds about one step, and a step that waited for its own division and TF
//! held back the next one's loads. A step of no length queues a segment of no length, which
//! composites as nothing, so the queue never has to be shaded early.
//!
//! Past 600 lines (about 630): the walk's inner loop and the queue it fills are one hot path,
//! kept in one file so that their layout decisions stay side by side.

use std::cell::Cell;

use glam::DVec3;
use rayon::prelude::*;

use super::bvh::Front;
use super::entry::EntryGrid;
use super::predicate::RayCtx;
use super::shade::{Queue, Shade, QUEUE};
use super::{Prepared, RayStats, Vert, TERMINATE_T};
use crate::mesh::{BOUNDARY, FACE_VERTS};
use crate::optics::{composite_under, Segment};
use crate::util::prefetch;

/// The unit roundoff, 2⁻⁵³.
const U: f64 = f64::EPSILON / 2.0;

/// A ray's 2-D frame and the static error bound of its products.
pub(super) struct Frame2<'a> {
    o: DVec3,
    /// The vertices in the frame's axes, when the frame is one all the frame's rays share
    /// ([`SharedFrame`]), and the ray's origin in them: a vertex is then `fl(p·f) − fl(o·f)`.
    shared: Option<(&'a SharedFrame, Local)>,
    d: DVec3,
    f1: DVec3,
    f2: DVec3,
    /// A computed product whose magnitude exceeds this has the exact orient3d's sign.
    bound: f64,
    /// `1 / |c|`: orient3d's value to the frame's scale.
    inv_len: f64,
    /// Products the bound could not decide, left to the exact predicate.
    fallbacks: Cell<u64>,
}

/// A vertex in a ray's frame: `(p − o)·f1`, `(p − o)·f2`, the depth `(p − o)·d` and the
/// transfer-function coordinate `s`.
#[derive(Clone, Copy)]
struct Local {
    x: f64,
    y: f64,
    z: f64,
    s: f64,
}

/// The axes `f1`, `f2` of the frame of the unit direction `ch` (`f1 × f2 = ch` up to
/// rounding): `f1` from the axis least aligned with it, `f2 = ch × f1`.
fn axes(ch: DVec3) -> (DVec3, DVec3) {
    let ax = ch.abs();
    let axis = if ax.x <= ax.y && ax.x <= ax.z {
        DVec3::X
    } else if ax.y <= ax.z {
        DVec3::Y
    } else {
        DVec3::Z
    };
    let f1 = ch.cross(axis).normalize();
    (f1, ch.cross(f1))
}

/// One frame for every ray of a direction `d` (the rays of an orthographic view), with every
/// vertex in it, `fl(p·f1)`, `fl(p·f2)`, `fl(p·d)` and `s`, computed once per image: a cell
/// step then subtracts the ray's origin, `fl(o·f)`, instead of taking three dot products.
pub(super) struct SharedFrame {
    d: DVec3,
    f1: DVec3,
    f2: DVec3,
    /// `fl(f1 × f2)`, which every ray's error bound measures against its own direction.
    n: DVec3,
    verts: Vec<Local>,
}

impl SharedFrame {
    /// The shared frame of direction `d` (`None` for a direction of no length).
    pub(super) fn new(verts: &[Vert], d: DVec3) -> Option<SharedFrame> {
        let len = d.length();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let (f1, f2) = axes(d / len);
        let verts = verts
            .par_iter()
            .map(|v| Local {
                x: v.p.dot(f1),
                y: v.p.dot(f2),
                z: v.p.dot(d),
                s: v.s,
            })
            .collect();
        Some(SharedFrame {
            d,
            f1,
            f2,
            n: f1.cross(f2),
            verts,
        })
    }

    /// Bytes the frame's vertex table holds.
    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(self.verts.as_slice())
    }
}

impl<'a> Frame2<'a> {
    /// The frame of `ray`; `max_abs` bounds every vertex coordinate. With `shared` (of the
    /// ray's direction), its axes and vertex table.
    ///
    /// Error bound. Let `A = max_abs + |o|∞` bound `|p_k − o_k|`, `D = q − o` the exact direction
    /// orient3d uses (`c = fl(q − o)` within `u·|D|` of it), and `x̃ = fl((p ⊖ o)·f1)`: its
    /// error against the real `(p − o)·f1` is at most `γ₄·√3·A·|f1| ≤ 6.93·u·A` (one subtraction,
    /// three products, two sums), and `|x̃| ≤ √3·A`. The computed cross product of two such
    /// vertices then differs from the real `(a × b)·(f1 × f2)` by at most
    /// `4·(6.93u·A)(√3·A) + 2u·(2·3A²) ≤ 60u·A²`, and that from `(a × b)·D̂` — whose sign is
    /// orient3d's — by at most `|a||b|·η ≤ 3A²·η`, `η = |f1 × f2 − D̂|`. `η` is the measured
    /// `|fl(f1 × f2) − ĉ|` plus the rounding of that measurement, of `ĉ` and of `c` against `D`
    /// (≤ 16u together). The bound is twice the sum, which also covers the rounding of the
    /// bound's own arithmetic.
    ///
    /// With a shared frame the axes are the direction's, not `ĉ`'s, and `η` measures that
    /// difference as well (it is the same expression). A vertex is `x̃ = fl(fl(p·f1) − fl(o·f1))`:
    /// the two dot products are within `γ₃·√3·max_abs` and `γ₃·√3·|o|∞` of their real values
    /// (`|f1| = 1` to rounding), and the subtraction adds `u·|x̃|`, so `x̃` is within
    /// `(γ₃ + u(1 + γ₃))·√3·A ≤ γ₄·√3·A` of `(p − o)·f1`, the per-coordinate error used above,
    /// so the derivation holds as it stands. Only `η` can be larger: orthographic origins lie
    /// ~2R from the centre, so the ray's `ĉ` may differ from the shared direction by ~R·u.
    pub(super) fn new(ray: &RayCtx, max_abs: f64, shared: Option<&'a SharedFrame>) -> Frame2<'a> {
        let c = ray.c;
        let len = c.length();
        let ch = if len > 0.0 { c / len } else { DVec3::Z };
        let shared = shared.filter(|sf| sf.d == ray.d);
        let (f1, f2, n) = match shared {
            Some(sf) => (sf.f1, sf.f2, sf.n),
            None => {
                let (f1, f2) = axes(ch);
                (f1, f2, f1.cross(f2))
            }
        };
        let shared = shared.map(|sf| {
            let o = ray.o;
            let at = Local {
                x: o.dot(f1),
                y: o.dot(f2),
                z: o.dot(sf.d),
                s: 0.0,
            };
            (sf, at)
        });
        let eta = (n - ch).length() * 1.01 + 16.0 * U;
        let a = max_abs + ray.o.abs().max_element();
        let bound = 2.0 * a * a * (60.0 * U + 3.0 * eta);
        Frame2 {
            o: ray.o,
            shared,
            d: ray.d,
            f1,
            f2,
            // A ray without a direction (never made by the camera) decides nothing itself.
            bound: if len > 0.0 && bound.is_finite() {
                bound
            } else {
                f64::INFINITY
            },
            inv_len: if len > 0.0 { 1.0 / len } else { 0.0 },
            fallbacks: Cell::new(0),
        }
    }

    /// Vertex `id` of `verts` in the frame.
    #[inline(always)]
    fn local(&self, verts: &[Vert], id: u32) -> Local {
        if let Some((sf, o)) = &self.shared {
            let v = &sf.verts[id as usize];
            return Local {
                x: v.x - o.x,
                y: v.y - o.y,
                z: v.z - o.z,
                s: v.s,
            };
        }
        let v = &verts[id as usize];
        let a = v.p - self.o;
        Local {
            x: a.dot(self.f1),
            y: a.dot(self.f2),
            z: a.dot(self.d),
            s: v.s,
        }
    }

    /// The product of the directed edge `a → b` (global ids `ia`, `ib`) and whether its sign
    /// is `w`: the 2-D product when the bound decides, else the exact predicate's sign and
    /// value (orient3d's, `|c|` times the 2-D product: so an edge the ray meets weighs exactly
    /// 0, as in the reference walk, where the 2-D product would be a rounding residue).
    #[inline(always)]
    fn side(
        &self,
        st: &Prepared,
        ray: &RayCtx,
        (ia, a): (u32, &Local),
        (ib, b): (u32, &Local),
        w: bool,
    ) -> (f64, bool) {
        let v = a.x * b.y - a.y * b.x;
        if v > self.bound {
            return (v, w);
        }
        if v < -self.bound {
            return (v, !w);
        }
        self.undecided(st, ray, ia, ib, w)
    }

    /// Whether the ray crosses triangle `tri` (global ids, circulation order) with all three
    /// edge products of sign `want`, as [`Prepared::cross_face`] decides it (the same exact
    /// signs: see [`Frame2::side`]); if so the depth and scalar of the crossing, interpolated
    /// as the walk interpolates its exits ([`Blend`]).
    #[inline(always)]
    pub(super) fn cross_face(
        &self,
        st: &Prepared,
        ray: &RayCtx,
        tri: [u32; 3],
        want: bool,
    ) -> Option<(f64, f64)> {
        let lv = tri.map(|v| self.local(&st.verts, v));
        let mut w = [0.0; 3];
        for (k, wk) in w.iter_mut().enumerate() {
            // Weight of vertex k is the product with the opposite edge.
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let (v, ok) = self.side(st, ray, (tri[a], &lv[a]), (tri[b], &lv[b]), want);
            if !ok {
                return None;
            }
            *wk = v.abs();
        }
        let wn = normalised(w);
        Some((
            wn[0] * lv[0].z + wn[1] * lv[1].z + wn[2] * lv[2].z,
            wn[0] * lv[0].s + wn[1] * lv[1].s + wn[2] * lv[2].s,
        ))
    }

    /// [`Frame2::side`] below the bound: the exact predicate, counted.
    #[cold]
    #[inline(never)]
    fn undecided(&self, st: &Prepared, ray: &RayCtx, ia: u32, ib: u32, w: bool) -> (f64, bool) {
        self.fallbacks.set(self.fallbacks.get() + 1);
        let (e, sign) = st.edge(ray, ia, ib);
        (e * self.inv_len, sign == w)
    }
}

/// Local index in `g` of vertex `v` (4 when absent).
#[inline(always)]
fn local_index(g: &[u32; 4], v: u32) -> usize {
    let m = (g[0] == v) as u32
        | ((g[1] == v) as u32) << 1
        | ((g[2] == v) as u32) << 2
        | ((g[3] == v) as u32) << 3;
    m.trailing_zeros().min(4) as usize
}

impl Prepared {
    /// Casts one ray with the projected walk; returns the composited pixel and the ray's
    /// counters. The entries (first and re-entries) come from the frame's [`EntryGrid`] when
    /// there is one (the faces and depths of [`Bvh::first_entry`]), else from the BVH as in
    /// [`Prepared::cast`].
    ///
    /// [`Bvh::first_entry`]: super::bvh::Bvh::first_entry
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn cast_projected<S: Shade>(
        &self,
        tets: &[[u32; 4]],
        shade: &S,
        front: &Front,
        ctx: &RayCtx,
        (grid, shared): (Option<&EntryGrid>, Option<&SharedFrame>),
        (i, j): (usize, usize),
        seed: &mut u32,
        run: &mut Run<S::End>,
    ) -> (Segment, RayStats) {
        let mut acc = Segment::default();
        let mut stats = RayStats::default();
        let mut t_min = f64::NEG_INFINITY;
        let mut exclude = u32::MAX;
        let mut first = true;
        // (The caller casts no ray whose pixel the grid rules out: `EntryGrid::may_cross`.)
        let fr = Frame2::new(ctx, self.max_abs, shared);
        // Entries from the frame's grid, tested in the frame (or the BVH, the first search
        // seeded with the previous ray's entry face).
        let entry = |t_min: f64, exclude: u32, seed: u32| match grid {
            Some(g) => g.first_entry(self, tets, (ctx, &fr), i, j, t_min, exclude),
            None => self
                .bvh
                .first_entry(self, tets, front, ctx, t_min, exclude, seed),
        };
        let mut found = entry(t_min, exclude, *seed);
        if found.is_none() {
            // A ray that enters nowhere: the check that it crosses no face.
            if self.bvh.any_crossing(self, tets, ctx) {
                stats.missed += 1;
            }
            stats.filter_fallbacks = ctx.fallbacks.get() + fr.fallbacks.get();
            return (acc, stats);
        }
        // Crossings wait in `run` and are interpolated, shaded and composited a queue at a time.
        // (Its rows are not cleared between rays: every entry starts with an empty queue, and
        // the lanes past it are computed and ignored.)
        run.q.n = 0;
        'rays: while let Some((bt, bf, t_in, s_in, leaf)) = found.take() {
            if first {
                *seed = leaf;
            } else {
                stats.reentries += 1;
            }
            first = false;
            // The entry face's products in circulation order have the entering sign `w`.
            let w = self.bvh.entering_sign(leaf);
            let mut tet = bt as usize;
            let mut g = tets[tet];
            let mut fin = bf;
            // The entry triangle in three slots, in circulation order. The exit face X Y D
            // keeps two of them, X = slot k + 1 and Y = slot k + 2 (mod 3), and drops slot k:
            // D takes its place, and the slots in order are (X, Y, D) rotated, the new entry
            // triangle in its circulation order. So a step writes one slot and moves nothing.
            let mut ids = FACE_VERTS[bf].map(|k| g[k]);
            let mut lv = ids.map(|v| fr.local(&self.verts, v));
            // |product| of the edge opposite each slot's vertex.
            let mut opp: [f64; 3] = std::array::from_fn(|k| {
                let (a, b) = ((k + 1) % 3, (k + 2) % 3);
                fr.side(self, ctx, (ids[a], &lv[a]), (ids[b], &lv[b]), w).0.abs()
            });
            // Slot `(i + rot) % 3` holds the i-th vertex of the entry triangle in the order
            // (X, Y, D) of the step that entered it (the entry face's order at first).
            let mut rot = 0;
            // The crossing the next segment starts from (the queue is empty between entries).
            run.q.ends[0] = shade.end(s_in);
            run.t = t_in;
            loop {
                // A step's loads are a chain, link → cell → vertex, each waiting on the one
                // before: ask for the cells across the three faces the ray may leave through
                // while this step waits for its vertex, so that the next step's cell is on its
                // way (0.91–0.94× the frame on blunt, comb and post).
                for (f, &nb) in self.next[tet].iter().enumerate() {
                    if f != fin {
                        prefetch(tets.as_ptr().wrapping_add(nb as usize / 4));
                    }
                }
                if stats.steps as usize >= self.max_steps {
                    // A ray that turns opaque on its queued segments stops before the limit
                    // (`drain` counts from the queue's last segment, this step's predecessor's);
                    // else it is lost on this step.
                    if !drain(shade, run, self.inv_l, &mut acc, &mut stats) {
                        stats.steps += 1;
                        stats.lost += 1;
                    }
                    break 'rays;
                }
                stats.steps += 1;
                let id = g[fin];
                let ld = fr.local(&self.verts, id);
                let (pa, ba) = fr.side(self, ctx, (ids[0], &lv[0]), (id, &ld), w);
                let (pb, bb) = fr.side(self, ctx, (ids[1], &lv[1]), (id, &ld), w);
                // k: the slot the exit face drops (ABD drops C, BCD A, CAD B).
                let mut p = [pa, pb, 0.0];
                let k = if !ba && bb {
                    2
                } else {
                    let (pc, bc) = fr.side(self, ctx, (ids[2], &lv[2]), (id, &ld), w);
                    p[2] = pc;
                    match (ba, bb, bc) {
                        (_, false, true) => 0,
                        (true, _, false) => 1,
                        _ => {
                            stats.fallbacks += 1;
                            // Its ties go to the first face in the order (X, Y, D) of the
                            // previous step, as when the walk kept its vertices in that order.
                            let pr = std::array::from_fn(|i| p[(i + rot) % 3]);
                            (closest_face(pr, w) + rot) % 3
                        }
                    }
                };
                // The exit face X Y D and the weights of X, Y, D: |Y → D|, |D → X|, |X → Y|
                // (carried), queued with the three vertices' depths and scalars: the crossing
                // is interpolated when the queue is shaded ([`drain`]).
                let (x, y) = ((k + 1) % 3, (k + 2) % 3);
                let wt = [p[y].abs(), p[x].abs(), opp[k]];
                let n = run.q.n;
                for (c, v) in [&lv[x], &lv[y], &ld].into_iter().enumerate() {
                    run.wt[c][n] = wt[c];
                    run.z[c][n] = v.z;
                    run.s[c][n] = v.s;
                }
                run.q.n += 1;
                if run.q.n == QUEUE && drain(shade, run, self.inv_l, &mut acc, &mut stats) {
                    break 'rays;
                }
                let iz = ids[k];
                let fz = local_index(&g, iz);
                let nb = if fz < 4 { self.next[tet][fz] } else { BOUNDARY };
                if nb == BOUNDARY {
                    if drain(shade, run, self.inv_l, &mut acc, &mut stats) {
                        break 'rays;
                    }
                    t_min = run.t;
                    exclude = if fz < 4 {
                        (4 * tet + fz) as u32
                    } else {
                        u32::MAX
                    };
                    break;
                }
                // D takes the dropped slot: X keeps |Y → D| opposite it, Y |D → X|, and D
                // |X → Y|, which slot k already holds.
                (ids[k], lv[k]) = (id, ld);
                (opp[x], opp[y]) = (wt[0], wt[1]);
                rot = x;
                tet = nb as usize / 4;
                fin = nb as usize % 4;
                g = tets[tet];
            }
            found = entry(t_min - self.t_eps, exclude, u32::MAX);
        }
        stats.filter_fallbacks = ctx.fallbacks.get() + fr.fallbacks.get();
        (acc, stats)
    }
}

/// A ray's queued crossings, before and after they are interpolated: per queued step the three
/// weights of the exit face's vertices and their depths and scalars (lane `k` of each row, the
/// step that queued segment `k`), and the depth `t` of the queue's first crossing (whose end,
/// for the shader, is `q.ends[0]`).
#[derive(Clone, Copy)]
pub(super) struct Run<E> {
    q: Queue<E>,
    wt: [[f64; QUEUE]; 3],
    z: [[f64; QUEUE]; 3],
    s: [[f64; QUEUE]; 3],
    t: f64,
    /// The instruction set [`Blend`] runs on, detected once per band.
    arch: pulp::Arch,
}

impl<E: Copy + Default> Default for Run<E> {
    fn default() -> Self {
        Run {
            q: Queue::default(),
            wt: [[0.0; QUEUE]; 3],
            z: [[0.0; QUEUE]; 3],
            s: [[0.0; QUEUE]; 3],
            t: 0.0,
            arch: pulp::Arch::new(),
        }
    }
}

/// Interpolates the queued crossings, shades the segments between them and composites them in
/// order; `true` when the ray terminated on one of them, with the step count put back to the
/// step that queued that segment, so that a ray counts the steps it would have counted
/// compositing segment by segment (the queue's last segment is the current step's: each step
/// queues one). The fallback counters keep the predicates and faces of the few steps walked
/// past it, which were computed (they were put back too, at 4 stores a step: post's frame
/// 3 070 M instructions with them, 2 988 M without).
///
/// A crossing's depth and scalar are the barycentric blend of its face's vertices with the
/// normalised weights (a third each where they sum to 0 or overflow), lane by lane; then, in
/// order, its depth no nearer than the previous crossing's (`t_out = max(t, t_in)`), the
/// segment's optical length `(t_out − t_in)/L` and the TF at its scalar. Segments of no length
/// (a step through an edge or a flat cell) shade as zero and composite as nothing: the next one
/// starts from their back crossing.
#[inline(always)]
fn drain<S: Shade>(
    shade: &S,
    run: &mut Run<S::End>,
    inv_l: f64,
    acc: &mut Segment,
    stats: &mut RayStats,
) -> bool {
    let n = run.q.n;
    if n == 0 {
        return false;
    }
    let (tt, sv) = run.arch.dispatch(Blend {
        wt: &run.wt,
        z: &run.z,
        s: &run.s,
    });
    let mut t_in = run.t;
    for k in 0..n {
        let t_out = tt[k].max(t_in);
        run.q.l[k] = (t_out - t_in) * inv_l;
        t_in = t_out;
        run.q.ends[k + 1] = shade.end(sv[k]);
    }
    run.t = t_in;
    let out = shade.segments(&run.q);
    run.q.n = 0;
    // The last crossing is the front of the walk's next segment.
    run.q.ends[0] = run.q.ends[n];
    // All n at once (a segment of no length shades as zero, a no-op), and the termination
    // test once: opacity only grows, so the ray turned opaque on one of them iff it is opaque
    // after all of them. Only then are they composited again, one by one as the reference
    // walk does, to stop on the one that made it opaque. The n are composited among
    // themselves first and the result onto the ray once ("under" is associative): the chain
    // of dependent operations through the ray's opacity is then one link a queue, not one a
    // segment, and the queue's own chain overlaps the walk (0.96–0.97× the frame on blunt,
    // comb and post; the f64 pixels move by a few ulps, the f32 images not at all).
    let before = *acc;
    let mut queued = Segment::default();
    for k in 0..n {
        composite_under(&mut queued, out.get(k));
    }
    composite_under(acc, queued);
    if 1.0 - acc.alpha >= TERMINATE_T {
        return false;
    }
    *acc = before;
    for k in 0..n {
        // (A step of no length queued a segment of no length: nothing to composite.)
        if run.q.l[k] > 0.0 {
            composite_under(acc, out.get(k));
            if 1.0 - acc.alpha < TERMINATE_T {
                // Each step queued one segment, the last of them the n-th: segment k was
                // queued by step `steps − n + k + 1`.
                stats.steps = stats.steps - n as u64 + k as u64 + 1;
                return true;
            }
        }
    }
    false
}

/// The queued crossings' depths and scalars: the barycentric blend of their faces' vertices
/// with the normalised weights (a third each where they sum to 0 or overflow), lane by lane, as
/// a `pulp` operation (AVX2 lanes where the CPU has them; the same operations, so the same bits
/// on any instruction set). Lanes past the queue are computed and ignored.
struct Blend<'a> {
    wt: &'a [[f64; QUEUE]; 3],
    z: &'a [[f64; QUEUE]; 3],
    s: &'a [[f64; QUEUE]; 3],
}

impl pulp::WithSimd for Blend<'_> {
    type Output = ([f64; QUEUE], [f64; QUEUE]);
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Self::Output {
        let (wt, z, s) = (self.wt, self.z, self.s);
        let (mut tt, mut sv) = ([0.0; QUEUE], [0.0; QUEUE]);
        for k in 0..QUEUE {
            let wn = normalised([wt[0][k], wt[1][k], wt[2][k]]);
            tt[k] = wn[0] * z[0][k] + wn[1] * z[1][k] + wn[2] * z[2][k];
            sv[k] = wn[0] * s[0][k] + wn[1] * s[1][k] + wn[2] * s[2][k];
        }
        (tt, sv)
    }
}

/// Barycentric weights scaled to sum 1, or a third each where they sum to 0, overflow or are
/// NaN.
#[inline(always)]
fn normalised(w: [f64; 3]) -> [f64; 3] {
    let sum = w[0] + w[1] + w[2];
    let r = 1.0 / sum;
    // `sum > 0` and finite, tested as `r > 0` (1/sum is 0 only for sum = +∞, and NaN for NaN):
    // two vector comparisons in the lane-wise blend, where LLVM made `is_finite` (and
    // `sum < ∞`) a dozen scalar bit-test instructions a lane.
    if (sum > 0.0) & (r > 0.0) {
        w.map(|v| v * r)
    } else {
        [1.0 / 3.0; 3]
    }
}

/// No exit face is consistent (a flat cell, or signs from a degenerate tie): the face whose
/// two apex products are closest to the exit's signs. `p[i]` is the product of entry vertex
/// `i` → apex; returns the entry vertex to drop.
#[cold]
fn closest_face(p: [f64; 3], w: bool) -> usize {
    let q = if w { p } else { p.map(|v| -v) };
    // Dropping k keeps X = k+1, Y = k+2, which want Y → D of sign w and X → D of sign !w.
    let score = |k: usize| q[(k + 2) % 3].min(-q[(k + 1) % 3]);
    let mut best = 0;
    for k in 1..3 {
        if score(k) > score(best) {
            best = k;
        }
    }
    best
}
