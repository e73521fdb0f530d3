//! The segment of one pixel ray through a tet, from the two faces a fan triangle lies under,
//! evaluated on the **unsnapped** projection.
//!
//! Coverage is decided on the snapped points (watertight, see [`super::raster`]), but the values
//! interpolated over a fan triangle from its snapped corners carry the snapping error times the
//! gradient of the interpolated quantity. Where a face is nearly edge-on that gradient is huge:
//! the thickness goes from 0 to the whole depth of the tet within a sliver a fraction of a pixel
//! wide, so a snap of 1/8192 pixel moves `l` by ~1 % (hard-mpvonc at view (270.28, −27.39),
//! 128²: faces 0.28° from edge-on, pixel centres 4·10⁻⁴ px from a projected edge; `l` 1.0 % low
//! on a whole pixel column, α 1.5·10⁻³ low).
//!
//! The ray through any point of fan triangle `(thick, x, y)` enters and leaves the tet through
//! the two faces that share the silhouette edge `(x, y)`: `{x, y, u}` and `{x, y, v}`, with `u`,
//! `v` the other two vertices (every class: the fan triangles of class 1 lie under the face
//! `{x, y, A}` and the face `{x, y, z}` of the big triangle; of class 2 under `{a0, b0, a1}` and
//! `{a0, b0, b1}`; of classes 3 and 4 likewise). So the depth and scalar on each of the two faces
//! at the pixel centre are 2-D barycentric interpolations on that face's own projected triangle
//! (in perspective of `1/z` and `s/z`, which are linear in screen space), and `l` is their depth
//! difference: exact for the true tet at every centre inside both faces' true projections,
//! whatever the fan's snapped shape. Two cases give `None`, and the caller keeps the snapped
//! interpolation: a centre in the snapped fan but outside a true face (a strip as wide as the
//! snapping error along the projected edges), and a face whose true projection has no area
//! (edge-on in f64). The snapped values are the consistent choice there: the snapped fans tile
//! the image exactly, so along a ray their thicknesses add up to the snapped mesh's depth, while
//! clamping to the true faces measured up to 1.3e-3 of `l` too much on a tet whose true
//! projection misses the centre (blunt, view (137.5, 0), 64², the z = 0 plane edge-on).

use super::Case;

/// One tet vertex as [`fan_segment`] needs it: continuous (unsnapped) pixel coordinates, depth
/// along the view axis and transfer-function coordinate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FaceVertex {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub s: f64,
}

/// The ray's segment through a tet at one pixel centre: front and back scalars and depths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceSegment {
    pub sf: f64,
    pub sb: f64,
    pub zf: f64,
    pub zb: f64,
}

/// Barycentric weights below −this put a centre outside a face (rounding of the weights is
/// ~1e-16 relative; a centre exactly on a true edge stays inside).
const OUTSIDE: f64 = 1e-9;

/// Depth and scalar of face `(a, b, c)` at pixel position `p`, or `None` when the face's
/// projection has no area or `p` is outside it. Ortho: `z` and `s` are linear in screen space; perspective: `1/z`
/// and `s/z` are (perspective-correct interpolation).
#[inline]
fn on_face(
    v: &[FaceVertex; 4],
    [a, b, c]: [usize; 3],
    p: [f64; 2],
    persp: bool,
) -> Option<(f64, f64)> {
    let (va, vb, vc) = (v[a], v[b], v[c]);
    // Coordinates relative to the pixel centre keep the cross products small and exact-ish.
    let r = |q: FaceVertex| [q.x - p[0], q.y - p[1]];
    let (ra, rb, rc) = (r(va), r(vb), r(vc));
    let cross = |u: [f64; 2], w: [f64; 2]| u[0] * w[1] - u[1] * w[0];
    // Twice the signed area and the sub-areas opposite each vertex (p at the origin).
    let wa = cross(rb, rc);
    let wb = cross(rc, ra);
    let wc = cross(ra, rb);
    let area = wa + wb + wc;
    let scale = [ra, rb, rc]
        .iter()
        .fold(0.0f64, |m, q| m.max(q[0].abs()).max(q[1].abs()));
    // Below this the area is rounding noise of the cross products: an edge-on face.
    if !area.is_finite() || area.abs() <= 1e-12 * scale * scale {
        return None;
    }
    let (la, lb, lc) = (wa / area, wb / area, wc / area);
    // Outside the face's true projection: a centre in the snapping strip (see the module docs).
    if la < -OUTSIDE || lb < -OUTSIDE || lc < -OUTSIDE {
        return None;
    }
    if persp {
        let iz = la / va.z + lb / vb.z + lc / vc.z;
        let sz = la * va.s / va.z + lb * vb.s / vb.z + lc * vc.s / vc.z;
        Some((1.0 / iz, sz / iz))
    } else {
        Some((
            la * va.z + lb * vb.z + lc * vc.z,
            la * va.s + lb * vb.s + lc * vc.s,
        ))
    }
}

/// The segment at pixel position `p` (continuous pixel coordinates) of the ray through fan
/// triangle `tri` of `case`, from the unsnapped vertices `v` (see the module docs); `None` when
/// one of the two faces is edge-on in `v`.
#[inline]
pub fn fan_segment(
    v: &[FaceVertex; 4],
    case: &Case,
    tri: usize,
    p: [f64; 2],
    persp: bool,
) -> Option<FaceSegment> {
    let (x, y) = (case.fan[tri] as usize, case.fan[tri + 1] as usize);
    // The other two vertices: 0+1+2+3 = 6, and u < v.
    let mut other = [0usize; 2];
    let mut n = 0;
    for k in 0..4 {
        if k != x && k != y {
            other[n] = k;
            n += 1;
        }
    }
    let (z0, s0) = on_face(v, [x, y, other[0]], p, persp)?;
    let (z1, s1) = on_face(v, [x, y, other[1]], p, persp)?;
    Some(if z0 <= z1 {
        FaceSegment {
            sf: s0,
            sb: s1,
            zf: z0,
            zb: z1,
        }
    } else {
        FaceSegment {
            sf: s1,
            sb: s0,
            zf: z1,
            zb: z0,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Camera, Projection, View};
    use crate::mesh::Aabb;
    use crate::render::pt::{classify, raster_fan, FanGeometry, ProjVertex, TABLE};
    use crate::util::rng::Rng;
    use glam::DVec3;

    /// The exact ray–tet segment (t_in, t_out) by clipping the ray against the four faces.
    fn clip(p: &[DVec3; 4], o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for f in 0..4 {
            let [a, b, c] = [(f + 1) % 4, (f + 2) % 4, (f + 3) % 4].map(|k| p[k]);
            let mut n = (b - a).cross(c - a);
            if n.dot(p[f] - a) < 0.0 {
                n = -n;
            }
            let (num, den) = (n.dot(o - a), n.dot(d));
            if den == 0.0 {
                if num < 0.0 {
                    return None;
                }
            } else if den > 0.0 {
                t0 = t0.max(-num / den);
            } else {
                t1 = t1.min(-num / den);
            }
        }
        (t0 < t1).then_some((t0, t1))
    }

    /// On random tets, flattened ones among them (faces near edge-on), the face segment is the
    /// exact ray–tet segment at the pixel centres, where the snapped fan interpolation is off by
    /// the snapping error times the gradient. Ortho and perspective.
    #[test]
    fn fan_segment_is_the_exact_ray_segment() {
        let bbox = Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
        };
        let mut rng = Rng::new(13);
        for proj in [Projection::Ortho, Projection::Persp] {
            let cam = Camera::new(&bbox, View::new(30.0, 20.0), proj, 64, 64);
            let persp = proj == Projection::Persp;
            let (mut n, mut exact, mut snapped_exact, mut worst) = (0usize, 0usize, 0usize, 0.0f64);
            let mut fallback = 0usize;
            for k in 0..400 {
                let mut p: [DVec3; 4] = std::array::from_fn(|_| {
                    DVec3::new(rng.f(), rng.f(), rng.f()) * 1.6 - DVec3::splat(0.8)
                });
                if k % 2 == 1 {
                    // Squash the tet along the view axis: faces within a degree of edge-on.
                    let c = (p[0] + p[1] + p[2] + p[3]) / 4.0;
                    let d = cam.to_eye;
                    for q in &mut p {
                        let t = (*q - c).dot(d);
                        *q -= 0.99 * t * d;
                    }
                }
                let v: [ProjVertex; 4] =
                    std::array::from_fn(|i| ProjVertex::project(&cam, p[i], 0.0));
                let fv: [FaceVertex; 4] = std::array::from_fn(|i| {
                    let (x, y, z) = cam.project(p[i]);
                    FaceVertex {
                        x,
                        y,
                        z,
                        s: i as f64,
                    }
                });
                let th = classify(&v, persp, 1.0);
                let case = &TABLE[th.case as usize];
                if !case.drawn() {
                    continue;
                }
                let g = FanGeometry::new(v.map(|v| v.q), &th);
                raster_fan(&g, [0, 0, 63, 63], |f| {
                    let c = [f.i as f64 + 0.5, f.j as f64 + 0.5];
                    let ray = cam.ray_at(c[0], c[1]);
                    let Some((t0, t1)) = clip(&p, ray.origin, ray.dir) else {
                        return; // a centre in the snapping strip outside the true tet
                    };
                    // Depth along the view axis: ortho the ray parameter itself (the ray
                    // starts on the plane of depth 0), persp its projection on the axis.
                    let dz = if persp { ray.dir.dot(cam.forward) } else { 1.0 };
                    let (zf, zb) = (t0 * dz, t1 * dz);
                    n += 1;
                    let Some(seg) = fan_segment(&fv, case, f.tri, c, persp) else {
                        fallback += 1; // outside a true face: the snapping strip
                        return;
                    };
                    let err = (seg.zf - zf).abs().max((seg.zb - zb).abs());
                    worst = worst.max(err);
                    exact += (err <= 1e-9) as usize;
                    // The snapped interpolation of the thickness, as cpu-pt did before (ortho,
                    // where it is linear; `l` is a world length here, inv_l = 1).
                    let l = (1.0 - f.lx - f.ly) * th.l;
                    snapped_exact += (!persp && (l - (t1 - t0)).abs() <= 1e-9) as usize;
                });
            }
            eprintln!(
                "{proj:?}: {n} fragments, {exact} exact to 1e-9 (worst {worst:.1e}), \
                 {fallback} in the snapping strip; snapped interpolation {snapped_exact} exact"
            );
            assert!(n > 10_000, "{n}");
            assert!(exact as f64 >= 0.995 * n as f64, "{exact} of {n}");
            assert!(
                (snapped_exact as f64) < 0.5 * n as f64,
                "{snapped_exact} of {n}"
            );
        }
    }
}
