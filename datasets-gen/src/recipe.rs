//! Sizing (how many cells per axis give a requested tet count) and recipes: a structured
//! block, graded, warped, with holes and jitter — how every irregular generator is made.

use glam::DVec3;

use crate::grid::{Block, Built, Split};
use crate::irregular::jitter;

/// Chooses a point count per axis, roughly proportional to `aspect`, whose `count` is closest to
/// `target` (relative error first, then closeness to the aspect). `min` is the smallest value
/// per axis; `even_x` asks for an even x (periodic 5-splits). `count` must grow with every axis.
pub fn fit_dims(
    target: f64,
    aspect: [f64; 3],
    min: usize,
    even_x: bool,
    count: &dyn Fn([usize; 3]) -> f64,
) -> [usize; 3] {
    let dims = |t: f64| aspect.map(|a| ((t * a).round() as usize).max(min));
    // Bisection on the scale t.
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while count(dims(hi)) < target && hi < 1e7 {
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if count(dims(mid)) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let t = hi;
    let base = dims(t);
    let mut best = (f64::INFINITY, base);
    let range = |c: usize, r: usize| (c.saturating_sub(r).max(min))..=(c + r);
    for nx in range(base[0], 3) {
        if even_x && nx % 2 == 1 {
            continue;
        }
        for ny in range(base[1], 3) {
            for nz in range(base[2], 4) {
                let d = [nx, ny, nz];
                let err = (count(d) - target).abs() / target.max(1.0);
                let shape = (0..3)
                    .map(|a| (d[a] as f64 / (t * aspect[a]).max(min as f64)).ln().abs())
                    .fold(0.0, f64::max);
                let score = err + 0.002 * shape;
                if score < best.0 {
                    best = (score, d);
                }
            }
        }
    }
    best.1
}

/// Cells per axis for a structured block with `split` and `fraction` of the cells kept.
pub fn fit_cells(
    target_tets: usize,
    split: Split,
    aspect: [f64; 3],
    even_x: bool,
    fraction: f64,
) -> [usize; 3] {
    let per = split.per_cell() as f64 * fraction;
    fit_dims(target_tets as f64, aspect, 1, even_x, &|d| {
        per * (d[0] * d[1] * d[2]) as f64
    })
}

/// A cell mask: true for the cells kept.
pub type CellMask<'a> = Box<dyn Fn([usize; 3]) -> bool + Sync + 'a>;

/// Sizes a masked block: `keep_for(cells)` is the cell mask for a block of that size. The
/// kept fraction is measured and the size corrected until the tet count is within 0.5 % of
/// `target` (at most 6 rounds; the closest size wins).
pub fn fit_masked<'a>(
    target: usize,
    split: Split,
    aspect: [f64; 3],
    periodic_x: bool,
    keep_for: &dyn Fn(&Block) -> CellMask<'a>,
) -> Block {
    let even = periodic_x && split == Split::Five;
    let mut fraction = 1.0;
    let mut best: Option<(f64, Block)> = None;
    for _ in 0..6 {
        let mut cells = fit_cells(target, split, aspect, even, fraction);
        if periodic_x {
            // A ring needs a few cells around it (and an even count for the 5-split).
            cells[0] = cells[0].max(4);
        }
        let block = Block {
            cells,
            split,
            periodic_x,
        };
        let kept = block.count_kept(&*keep_for(&block));
        let tets = kept * split.per_cell();
        let err = (tets as f64 - target as f64).abs() / target as f64;
        if best.as_ref().is_none_or(|b| err < b.0) {
            best = Some((err, block));
        }
        if err < 0.005 || kept == 0 {
            break;
        }
        fraction = kept as f64 / block.num_cells() as f64;
    }
    best.expect("at least one round").1
}

/// Parameter-space grading of one axis, `[0, 1] → [0, 1]`, increasing.
pub type Grading<'a> = &'a (dyn Fn(f64) -> f64 + Sync);

/// The uniform grading: equal cell sizes along the axis.
pub fn lin(t: f64) -> f64 {
    t
}

/// How an irregular mesh is made from a structured block.
pub struct Recipe<'a> {
    pub split: Split,
    /// Wrap the x axis of the parameter box around (rings, tubes).
    pub periodic_x: bool,
    /// Cells per axis are kept roughly proportional to this.
    pub aspect: [f64; 3],
    /// Grading of each parameter axis (cell sizes vary along it).
    pub grading: [Grading<'a>; 3],
    /// The graded parameter box `[0, 1]³` → world (orientation-preserving or -reversing).
    pub warp: &'a (dyn Fn(DVec3) -> DVec3 + Sync),
    /// Cells whose warped centre this returns true for are removed.
    pub hole: Option<&'a (dyn Fn(DVec3) -> bool + Sync)>,
    /// Jitter of interior vertices, as a fraction of their shortest edge (0: none).
    pub jitter: f64,
}

/// The result of [`Recipe::build`].
pub struct Planned {
    pub block: Block,
    pub built: Built,
    /// Boundary faces the kept cells imply ([`block_boundary_faces`]).
    pub expected_boundary: usize,
}

impl<'a> Recipe<'a> {
    /// A recipe for `warp` of a uniform, non-periodic block of cubic aspect, without holes
    /// or jitter (set the other fields with `..Recipe::new(split, warp)`).
    pub fn new(split: Split, warp: &'a (dyn Fn(DVec3) -> DVec3 + Sync)) -> Recipe<'a> {
        Recipe {
            split,
            periodic_x: false,
            aspect: [1.0, 1.0, 1.0],
            grading: [&lin, &lin, &lin],
            warp,
            hole: None,
            jitter: 0.0,
        }
    }

    fn param(&self, block: &Block, ijk: [f64; 3]) -> DVec3 {
        DVec3::new(
            (self.grading[0])(ijk[0] / block.cells[0] as f64),
            (self.grading[1])(ijk[1] / block.cells[1] as f64),
            (self.grading[2])(ijk[2] / block.cells[2] as f64),
        )
    }

    /// The cell mask for a block of this recipe.
    pub fn keep<'b>(&'b self, block: &Block) -> CellMask<'b> {
        let block = *block;
        match self.hole {
            None => Box::new(|_| true),
            Some(h) => Box::new(move |[i, j, k]| {
                let c = self.param(&block, [i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5]);
                !h((self.warp)(c))
            }),
        }
    }

    /// Sizes the block for `target` tets, builds it and jitters it (with `seed`).
    pub fn build(&self, target: usize, seed: u64) -> Planned {
        let block = fit_masked(target, self.split, self.aspect, self.periodic_x, &|b| {
            self.keep(b)
        });
        let keep = self.keep(&block);
        let mut built = block.build(&*keep, &|[i, j, k]| {
            (self.warp)(self.param(&block, [i as f64, j as f64, k as f64]))
        });
        if self.jitter > 0.0 {
            let movable = built.interior.clone();
            jitter(
                &mut built.positions,
                &built.tets,
                &movable,
                self.jitter,
                0.2,
                seed,
            );
        }
        let expected_boundary = block_boundary_faces(&block, &*keep);
        Planned {
            block,
            built,
            expected_boundary,
        }
    }
}

/// Boundary faces a masked block must have: two triangles for every square cell face between
/// a kept cell and a removed cell or the outside (periodic x wraps).
pub fn block_boundary_faces(block: &Block, keep: &(dyn Fn([usize; 3]) -> bool + Sync)) -> usize {
    let [cx, cy, cz] = block.cells;
    let kept = |i: isize, j: isize, k: isize| -> bool {
        let i = if block.periodic_x {
            i.rem_euclid(cx as isize)
        } else {
            i
        };
        i >= 0
            && j >= 0
            && k >= 0
            && (i as usize) < cx
            && (j as usize) < cy
            && (k as usize) < cz
            && keep([i as usize, j as usize, k as usize])
    };
    let mut faces = 0;
    for k in 0..cz as isize {
        for j in 0..cy as isize {
            for i in 0..cx as isize {
                if !kept(i, j, k) {
                    continue;
                }
                for (di, dj, dk) in [
                    (1, 0, 0),
                    (-1, 0, 0),
                    (0, 1, 0),
                    (0, -1, 0),
                    (0, 0, 1),
                    (0, 0, -1),
                ] {
                    if !kept(i + di, j + dj, k + dk) {
                        faces += 2;
                    }
                }
            }
        }
    }
    faces
}
