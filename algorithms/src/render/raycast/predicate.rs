//! The ray's edge predicate: the Plücker product of the ray with a directed edge as Shewchuk's
//! orient3d, filtered by a static per-ray error bound, with a Simulation-of-Simplicity tie rule.

use std::cell::Cell;

use glam::DVec3;

use crate::camera::{Camera, Ray};

/// A ray with the perturbation directions of the Simulation of Simplicity tie-break.
pub(super) struct RayCtx {
    pub(super) o: DVec3,
    pub(super) d: DVec3,
    /// `1 / d` per coordinate, for the BVH's slab test.
    pub(super) inv_d: DVec3,
    /// A second point on the ray, `o + d`: with `o` it defines the line every predicate uses.
    q: DVec3,
    /// d × r and d × u: first- and second-order terms of the perturbed products.
    d_r: DVec3,
    d_u: DVec3,
    /// `q − o`, the column every orient3d of this ray shares, as orient3d computes it.
    pub(super) c: DVec3,
    /// Static error bound of the f64 filter for this ray (see [`RayCtx::orient`]).
    bound: f64,
    /// Predicates the filter left to the exact orient3d.
    pub(super) fallbacks: Cell<u64>,
}

/// Shewchuk's error-bound coefficient of orient3d's first stage, `(7 + 56ε)ε`, ε = 2⁻⁵³.
const O3D_ERRBOUND_A: f64 = (7.0 + 56.0 * f64::EPSILON / 2.0) * f64::EPSILON / 2.0;

#[inline]
pub(super) fn coord(p: DVec3) -> robust::Coord3D<f64> {
    robust::Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// The terms of a ray that depend only on its direction, computed once for all the rays of a
/// direction (an orthographic view's): the same expressions, so the same bits.
pub(super) struct DirTerms {
    d: DVec3,
    d_r: DVec3,
    d_u: DVec3,
    inv_d: DVec3,
}

impl DirTerms {
    pub(super) fn new(d: DVec3, cam: &Camera) -> DirTerms {
        DirTerms {
            d,
            d_r: d.cross(cam.right),
            d_u: d.cross(cam.up),
            inv_d: DVec3::ONE / d,
        }
    }
}

impl RayCtx {
    /// `max_abs` bounds every vertex coordinate the ray is tested against. `dir` holds the
    /// terms of the ray's direction (those of another ray are ignored).
    pub(super) fn new(ray: &Ray, cam: &Camera, max_abs: f64, dir: Option<&DirTerms>) -> RayCtx {
        let own;
        let dir = match dir {
            Some(t) if t.d == ray.dir => t,
            _ => {
                own = DirTerms::new(ray.dir, cam);
                &own
            }
        };
        let (o, q) = (ray.origin, ray.origin + ray.dir);
        let c = q - o;
        // |u − o|, |v − o| ≤ a and |q − o| ≤ cm per coordinate, so orient3d's permanent is at
        // most 6·a²·cm (three terms of two products each) and its dynamic bound
        // O3D_ERRBOUND_A·permanent at most this static one (the factor covers the rounding
        // of the bound's own arithmetic, ~10 ε).
        let a = max_abs + o.abs().max_element();
        let cm = c.abs().max_element();
        RayCtx {
            o,
            d: ray.dir,
            q,
            d_r: dir.d_r,
            d_u: dir.d_u,
            inv_d: dir.inv_d,
            c,
            bound: O3D_ERRBOUND_A * 6.0 * a * a * cm * (1.0 + 1e-12),
            fallbacks: Cell::new(0),
        }
    }

    /// `orient3d(u, v, q, o) = det[u − o, v − o, q − o]`, filtered: orient3d's own first stage
    /// (the same expression, so the same bits) is accepted when it exceeds the static bound of
    /// this ray, which is never below orient3d's dynamic one — so the result is bit for bit
    /// what `robust::orient3d` returns, without its permanent and call. Otherwise (the
    /// filter cannot decide the sign) the exact adaptive predicate is called and counted.
    #[inline(always)]
    fn orient(&self, pu: DVec3, pv: DVec3) -> f64 {
        let (o, c) = (self.o, self.c);
        let (adx, ady, adz) = (pu.x - o.x, pu.y - o.y, pu.z - o.z);
        let (bdx, bdy, bdz) = (pv.x - o.x, pv.y - o.y, pv.z - o.z);
        let (cdx, cdy, cdz) = (c.x, c.y, c.z);
        let bdxcdy = bdx * cdy;
        let cdxbdy = cdx * bdy;
        let cdxady = cdx * ady;
        let adxcdy = adx * cdy;
        let adxbdy = adx * bdy;
        let bdxady = bdx * ady;
        let det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
        if det > self.bound || -det > self.bound {
            return det;
        }
        self.fallbacks.set(self.fallbacks.get() + 1);
        robust::orient3d(coord(pu), coord(pv), coord(self.q), coord(self.o))
    }

    /// Plücker product of the ray with the edge from `u` to `v` (callers pass the lower global
    /// index first), `det[u − o, v − o, q − o]`, with an exact sign (Shewchuk's adaptive
    /// orient3d): every decision is then that of one real line, the one through `o` and `q`.
    /// Returns the value and its sign after the symbolic perturbation.
    #[inline]
    pub(super) fn side(&self, pu: DVec3, pv: DVec3) -> (f64, bool) {
        let p = self.orient(pu, pv);
        if p != 0.0 {
            return (p, p > 0.0);
        }
        // The line meets the edge's line: shift it by ε·r + ε²·u. The ε-term of
        // det[u − o − εδ, v − o − εδ, d] is det[δ, u − v, d] = (u − v)·(d × δ).
        let e = pu - pv;
        let p1 = e.dot(self.d_r);
        if p1 != 0.0 {
            return (0.0, p1 > 0.0);
        }
        (0.0, e.dot(self.d_u) >= 0.0)
    }
}
