//! The camera of CONVENTIONS §2. All rays are given in the frame centred on the mesh's
//! bounding-box centre `C` (CONVENTIONS §1), so that a mesh far from the origin renders the same
//! as one at the origin.

use glam::DVec3;

use crate::error::{Error, Result};
use crate::mesh::Aabb;

/// Orthographic (default) or perspective projection.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Projection {
    #[default]
    Ortho,
    Persp,
}

impl Projection {
    pub fn name(self) -> &'static str {
        match self {
            Projection::Ortho => "ortho",
            Projection::Persp => "persp",
        }
    }
    pub fn parse(s: &str) -> Result<Projection> {
        match s {
            "ortho" => Ok(Projection::Ortho),
            "persp" => Ok(Projection::Persp),
            _ => Err(Error::Input(format!(
                "unknown projection '{s}' (known: ortho, persp)"
            ))),
        }
    }
}

/// A view direction: azimuth and elevation in degrees.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct View {
    pub azimuth: f64,
    pub elevation: f64,
}

impl View {
    pub fn new(azimuth: f64, elevation: f64) -> View {
        View { azimuth, elevation }
    }
    /// Parses `AZ,EL`.
    pub fn parse(s: &str) -> Result<View> {
        let bad = || {
            Error::Input(format!(
                "--view '{s}': expected AZ,EL in degrees, e.g. 30,20"
            ))
        };
        let (a, e) = s.split_once(',').ok_or_else(bad)?;
        let a: f64 = a.trim().parse().map_err(|_| bad())?;
        let e: f64 = e.trim().parse().map_err(|_| bad())?;
        if !a.is_finite() || !e.is_finite() || e.abs() > 90.0 {
            return Err(bad());
        }
        Ok(View::new(a, e))
    }
    /// Unit direction from the centre towards the eye, `d` of §2.
    pub fn to_eye(&self) -> DVec3 {
        let (a, e) = (self.azimuth.to_radians(), self.elevation.to_radians());
        DVec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos())
    }
}

/// N views spread over the sphere (Fibonacci points, §2).
pub fn fibonacci_views(n: usize) -> Vec<View> {
    (0..n)
        .map(|k| {
            let e = (1.0 - 2.0 * (k as f64 + 0.5) / n as f64)
                .asin()
                .to_degrees();
            let a = (k as f64 * 137.507764) % 360.0;
            View::new(a, e)
        })
        .collect()
}

/// A ray in the centred frame; `dir` has unit length, so `t` is a world length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub dir: DVec3,
}

/// The camera for one image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub projection: Projection,
    pub view: View,
    pub width: u32,
    pub height: u32,
    /// Bounding-box centre `C` in world coordinates (the origin of the centred frame).
    pub center: DVec3,
    /// `R = L / 2`.
    pub radius: f64,
    /// Towards the eye (`d`), forward (`f = −d`), right and up (§2).
    pub to_eye: DVec3,
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    /// Pixel size in world units at the centre plane, `p = 2R / min(W, H)`.
    pub pixel: f64,
}

impl Camera {
    pub fn new(bbox: &Aabb, view: View, projection: Projection, width: u32, height: u32) -> Camera {
        let radius = 0.5 * bbox.diagonal();
        let d = view.to_eye();
        let f = -d;
        let w = if view.elevation.abs() > 89.9 {
            DVec3::new(0.0, 0.0, -view.elevation.signum())
        } else {
            DVec3::Y
        };
        let right = f.cross(w).normalize();
        let up = right.cross(f);
        Camera {
            projection,
            view,
            width,
            height,
            center: bbox.center(),
            radius,
            to_eye: d,
            forward: f,
            right,
            up,
            pixel: 2.0 * radius / width.min(height).max(1) as f64,
        }
    }

    /// Image-plane coordinates (x, y) of the continuous pixel position (px, py); the pixel
    /// (i, j) has its centre at (i + 0.5, j + 0.5).
    #[inline]
    pub fn plane_xy(&self, px: f64, py: f64) -> (f64, f64) {
        (
            (px - 0.5 * self.width as f64) * self.pixel,
            (0.5 * self.height as f64 - py) * self.pixel,
        )
    }

    /// The eye in the centred frame (perspective only).
    pub fn eye(&self) -> DVec3 {
        3.0 * self.radius * self.to_eye
    }

    /// The ray through continuous pixel position (px, py), in the centred frame.
    #[inline]
    pub fn ray_at(&self, px: f64, py: f64) -> Ray {
        let (x, y) = self.plane_xy(px, py);
        let on_plane = x * self.right + y * self.up;
        match self.projection {
            Projection::Ortho => Ray {
                origin: on_plane + 2.0 * self.radius * self.to_eye,
                dir: self.forward,
            },
            Projection::Persp => {
                let eye = self.eye();
                Ray {
                    origin: eye,
                    dir: (on_plane - eye).normalize(),
                }
            }
        }
    }

    /// The ray through the centre of pixel (i, j).
    #[inline]
    pub fn pixel_ray(&self, i: u32, j: u32) -> Ray {
        self.ray_at(i as f64 + 0.5, j as f64 + 0.5)
    }

    /// Projects a point of the centred frame to (px, py, depth): continuous pixel coordinates
    /// and the distance along the view axis from the eye (ortho: from the plane at 2R in front
    /// of C). Inverse of [`Camera::ray_at`] on the image plane.
    #[inline]
    pub fn project(&self, p: DVec3) -> (f64, f64, f64) {
        let (x, y, depth) = match self.projection {
            Projection::Ortho => (
                p.dot(self.right),
                p.dot(self.up),
                2.0 * self.radius - p.dot(self.to_eye),
            ),
            Projection::Persp => {
                let v = p - self.eye();
                let z = v.dot(self.forward); // distance along the axis
                let s = 3.0 * self.radius / z;
                (v.dot(self.right) * s, v.dot(self.up) * s, z)
            }
        };
        (
            x / self.pixel + 0.5 * self.width as f64,
            0.5 * self.height as f64 - y / self.pixel,
            depth,
        )
    }
}

// The fixed-point pixel grid. Projected vertices are snapped to 1/SUBPIXEL pixel so that
// every coverage decision of projected tetrahedra (`render::pt`), of the GPU renderers'
// snapping (`view.wgsl`) and of XMPVO's exterior order is exact integer arithmetic.

/// Bits of sub-pixel precision of the snapped vertex coordinates.
pub const SUBPIXEL_BITS: u32 = 12;
/// Snapped units per pixel.
pub const SUBPIXEL: i64 = 1 << SUBPIXEL_BITS;
/// Projected coordinates are clamped to ±this many pixels, which keeps every cross product of
/// snapped coordinates (|x| < 2^30) exact in i64.
pub const MAX_PIXEL_COORD: f64 = (1u64 << (30 - SUBPIXEL_BITS)) as f64;

/// Snaps a continuous pixel coordinate to the fixed-point grid (round to nearest).
#[inline]
pub fn snap(px: f64) -> i64 {
    // NaN clamps to NaN and converts to 0; positions are finite by construction.
    (px.clamp(-MAX_PIXEL_COORD, MAX_PIXEL_COORD) * SUBPIXEL as f64).round() as i64
}

/// The snapped position of the centre of pixel `i` (column or row).
#[inline]
pub fn pixel_centre(i: i64) -> i64 {
    (i << SUBPIXEL_BITS) + SUBPIXEL / 2
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> Aabb {
        Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
        }
    }

    #[test]
    fn view_zero_looks_down_minus_z() {
        let c = Camera::new(&unit_box(), View::new(0.0, 0.0), Projection::Ortho, 4, 2);
        assert!((c.forward - DVec3::NEG_Z).length() < 1e-15);
        assert!((c.right - DVec3::X).length() < 1e-15);
        assert!((c.up - DVec3::Y).length() < 1e-15);
        // R = sqrt(3), p = 2R / 2 = sqrt(3); pixel (0, 0) centre: x = (0.5 − 2)·p, y = (1 − 0.5)·p.
        let r = c.pixel_ray(0, 0);
        let p = 3f64.sqrt();
        assert!((r.origin - DVec3::new(-1.5 * p, 0.5 * p, 2.0 * p)).length() < 1e-12);
        assert_eq!(r.dir, DVec3::NEG_Z);
    }

    #[test]
    fn view_90_0_looks_down_minus_x_and_poles_use_alternative_up() {
        let c = Camera::new(&unit_box(), View::new(90.0, 0.0), Projection::Ortho, 8, 8);
        assert!((c.forward - DVec3::NEG_X).length() < 1e-12);
        assert!((c.right - DVec3::NEG_Z).length() < 1e-12);
        let top = Camera::new(&unit_box(), View::new(0.0, 90.0), Projection::Ortho, 8, 8);
        assert!((top.forward - DVec3::NEG_Y).length() < 1e-12);
        // w = (0, 0, −1): r = f × w = (−y) × (−z) = x.
        assert!((top.right - DVec3::X).length() < 1e-12);
        assert!((top.up - DVec3::NEG_Z).length() < 1e-12);
    }

    #[test]
    fn perspective_rays_pass_through_the_centre_plane_square() {
        let c = Camera::new(
            &unit_box(),
            View::new(30.0, 20.0),
            Projection::Persp,
            16,
            16,
        );
        let o = Camera::new(
            &unit_box(),
            View::new(30.0, 20.0),
            Projection::Ortho,
            16,
            16,
        );
        for (i, j) in [(0, 0), (7, 3), (15, 15)] {
            let r = c.pixel_ray(i, j);
            let ro = o.pixel_ray(i, j);
            // Where the ortho ray crosses the plane through C, the persp ray crosses too.
            let target = ro.origin - 2.0 * o.radius * o.to_eye;
            let t = (target - r.origin).dot(r.dir);
            assert!((r.origin + t * r.dir - target).length() < 1e-12);
            // project() inverts ray_at for points on and off the plane.
            for s in [0.3, 1.0, 1.7] {
                let (px, py, _) = c.project(r.origin + s * t * r.dir);
                assert!(
                    (px - (i as f64 + 0.5)).abs() < 1e-9 && (py - (j as f64 + 0.5)).abs() < 1e-9
                );
            }
            let (px, py, depth) = o.project(target);
            assert!((px - (i as f64 + 0.5)).abs() < 1e-9 && (py - (j as f64 + 0.5)).abs() < 1e-9);
            assert!((depth - 2.0 * o.radius).abs() < 1e-12);
        }
    }

    #[test]
    fn fibonacci_views_match_the_formula() {
        let v = fibonacci_views(4);
        assert!((v[0].elevation - 0.75f64.asin().to_degrees()).abs() < 1e-12);
        assert!((v[1].azimuth - 137.507764).abs() < 1e-12);
        assert!((v[2].azimuth - 275.015528).abs() < 1e-9);
        assert!((v[3].azimuth - (3.0 * 137.507764 - 360.0)).abs() < 1e-9);
        assert!((v[3].elevation + 0.75f64.asin().to_degrees()).abs() < 1e-12);
    }

    #[test]
    fn parses_views() {
        assert_eq!(View::parse("30,-20").unwrap(), View::new(30.0, -20.0));
        assert!(View::parse("30").is_err());
        assert!(View::parse("a,b").is_err());
        assert!(View::parse("0,95").is_err());
    }
}
