//! `cpu-pt`'s project stage: every vertex to snapped pixel coordinates and depth, every tet of
//! a part of the visibility order classified by the ternary truth table of
//! [`crate::render::pt`] and given its tile range; for the fast path, the tet's [`FastRec`]
//! written at its place in the part.

use glam::DVec3;
use rayon::prelude::*;

use super::fast::FastRec;
use super::{Prepared, Scratch, TILE};
use crate::util::prefetch;
use crate::camera::{Camera, Projection};
use crate::mesh::Mesh;
use crate::render::pt::{
    classify, classify_ortho, pixel_box, snap, table_index, tests, FanGeometry, ProjVertex,
    Thick, TABLE,
};

/// Tets a task of the fast path's project stage takes.
const CHUNK: usize = 4096;

/// A projected vertex: snapped pixel coordinates and depth along the view axis, and beside
/// them copies of the vertex's centred position and transfer-function coordinate, so that the
/// project stage reads one 32-byte line per vertex of a tet instead of three records at random
/// (`project_ms` 0.865 on post at 512², 10 pairs; 16 more bytes of scratch a vertex).
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
pub(super) struct VertProj {
    pub(super) q: [i32; 2],
    pub(super) z: f64,
    pub(super) p: [f32; 3],
    pub(super) s: f32,
}

/// A classified tet (general path).
#[derive(Clone, Copy, Default)]
pub(super) struct TetProj {
    pub(super) thick: Thick,
}

/// The tile range of a tet, inclusive (empty, `[1, 1, 0, 0]`, when not drawn).
pub(super) type TileRect = [u16; 4];
pub(super) const NO_TILES: TileRect = [1, 1, 0, 0];

/// Every vertex of `st` to snapped pixel coordinates and depth for `camera`, into `verts` (the
/// first part of the project stage; it needs no order, so it runs beside the sort).
pub(super) fn project_verts(st: &Prepared, camera: &Camera, verts: &mut Vec<VertProj>) {
    st.pos
        .par_iter()
        .zip(st.s.par_iter())
        .map(|(p, &s)| {
            let (x, y, z) = camera.project(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            VertProj {
                q: [snap(x) as i32, snap(y) as i32],
                z,
                p: *p,
                s,
            }
        })
        .collect_into_vec(verts);
}

/// Classifies the tets of `part` (a run of places of the visibility order) for `camera` into
/// `sc`, by their place in the part: on the fast path (`fast`) a record and a tile range
/// (`fast[i]` and `rects[i]` for tet `part[i]`), on the general path a classification and a
/// tile range (`tets[i]`, `rects[i]`). Returns how many of them are of a drawn class (counted
/// here, in parallel, rather than by a serial pass over the records afterwards: 1.4 ms of
/// post's frame at 512²). (`sc.verts` must hold [`project_verts`]'s output for this camera.)
pub(super) fn project(
    st: &Prepared,
    mesh: &Mesh,
    camera: &Camera,
    part: &[u32],
    fast: bool,
    sc: &mut Scratch,
) -> usize {
    let (w, h) = (camera.width, camera.height);
    let persp = camera.projection == Projection::Persp;
    let verts = &sc.verts;
    // The tile range of a drawn tet's pixel box (empty when no centre is inside the image).
    let tiles_of = |b: [i64; 4]| {
        let (i0, j0) = (b[0].max(0), b[1].max(0));
        let (i1, j1) = (b[2].min(w as i64 - 1), b[3].min(h as i64 - 1));
        if i0 > i1 || j0 > j1 {
            return NO_TILES;
        }
        let t = TILE as i64;
        [
            (i0 / t) as u16,
            (j0 / t) as u16,
            (i1 / t) as u16,
            (j1 / t) as u16,
        ]
    };
    let classify_tet = |t: &[u32; 4]| {
        let v: [ProjVertex; 4] = std::array::from_fn(|k| {
            let v = &verts[t[k] as usize];
            ProjVertex {
                q: [v.q[0] as i64, v.q[1] as i64],
                z: v.z,
                p: DVec3::new(v.p[0] as f64, v.p[1] as f64, v.p[2] as f64),
                s: v.s as f64,
            }
        });
        let thick = classify(&v, persp, st.inv_l);
        let mut tiles = NO_TILES;
        if TABLE[thick.case as usize].drawn() {
            tiles = tiles_of(FanGeometry::new(v.map(|v| v.q), &thick).pixel_bounds());
        }
        (thick, tiles)
    };
    let tets = mesh.tets();
    sc.rects.resize(part.len(), NO_TILES);
    if fast {
        sc.fast.resize(part.len(), FastRec::default());
        let (fr, rects) = (&mut sc.fast, &mut sc.rects);
        part.par_chunks(CHUNK)
            .zip(fr.par_chunks_mut(CHUNK).zip(rects.par_chunks_mut(CHUNK)))
            .map(|(ids, (fr, rects))| {
                pulp::Arch::new().dispatch(FastChunk {
                    ids,
                    fr,
                    rects,
                    tets,
                    verts,
                    inv_l: st.inv_l,
                    tiles_of: &tiles_of,
                })
            })
            .sum()
    } else {
        sc.tets.resize(part.len(), TetProj::default());
        let (tp, rects) = (&mut sc.tets, &mut sc.rects);
        part.par_iter()
            .zip(tp.par_iter_mut().zip(rects.par_iter_mut()))
            .map(|(&t, (p, r))| {
                let (thick, tiles) = classify_tet(&tets[t as usize]);
                *r = tiles;
                *p = TetProj { thick };
                TABLE[thick.case as usize].drawn() as usize
            })
            .sum()
    }
}

/// One chunk of the fast path's project stage: the tets `ids` (places of the visibility order)
/// classified into their records `fr` and tile ranges `rects`; returns how many are drawn. Run
/// under `pulp`'s dispatch, so that `classify_ortho`'s f64 arithmetic is compiled for the CPU's
/// vectors (AVX2 where it has them: the baseline is SSE2), with the same operations, so the same
/// bits.
struct FastChunk<'a, F> {
    ids: &'a [u32],
    fr: &'a mut [FastRec],
    rects: &'a mut [TileRect],
    tets: &'a [[u32; 4]],
    verts: &'a [VertProj],
    inv_l: f64,
    tiles_of: &'a F,
}

impl<F: Fn([i64; 4]) -> TileRect> pulp::WithSimd for FastChunk<'_, F> {
    type Output = usize;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> usize {
        let FastChunk { ids, fr, rects, tets, verts, inv_l, tiles_of } = self;
        // In the visibility order the tets and their vertices are read at random: each chunk
        // asks for the tet `AHEAD` places ahead, and for the vertices of the one half as far
        // ahead (whose tet was asked for then).
        const AHEAD: usize = 16;
        let mut drawn = 0;
        for (n, (&t, (f, r))) in ids.iter().zip(fr.iter_mut().zip(rects)).enumerate() {
            if let Some(&a) = ids.get(n + AHEAD) {
                prefetch(&tets[a as usize]);
            }
            if let Some(&a) = ids.get(n + AHEAD / 2) {
                for &v in &tets[a as usize] {
                    prefetch(&verts[v as usize]);
                }
            }
            let t = &tets[t as usize];
            // The fast path is orthographic: `classify_ortho`, which computes only what the
            // record keeps, from the vertices' values read once.
            // (References: copying the four 32-byte lines to the stack first was ~29
            // instructions a tet.)
            let vp = t.map(|v| &verts[v as usize]);
            let q = vp.map(|v| [v.q[0] as i64, v.q[1] as i64]);
            let rect = tiles_of(pixel_box(&q));
            if rect == NO_TILES {
                // No pixel centre of the image in its box: the tet is in no tile, so its record
                // is never read. Only its class is counted (`tets_drawn`); its hull points, ~120
                // instructions, and its record's write are skipped.
                drawn += TABLE[table_index(&tests(&q))].drawn() as usize;
                *r = NO_TILES;
                continue;
            }
            let p = vp.map(|v| DVec3::new(v.p[0] as f64, v.p[1] as f64, v.p[2] as f64));
            let s = vp.map(|v| v.s);
            let (case, [sf, sb, l]) =
                classify_ortho(&q, &vp.map(|v| v.z), &p, &s.map(f64::from), inv_l);
            let is_drawn = TABLE[case as usize].drawn();
            drawn += is_drawn as usize;
            *r = if is_drawn { rect } else { NO_TILES };
            *f = FastRec {
                q: vp.map(|v| v.q),
                s,
                sf: sf as f32,
                sb: sb as f32,
                l: l as f32,
                case,
            };
        }
        drawn
    }
}
