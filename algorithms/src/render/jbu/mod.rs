//! Joint bilateral upsampling (Callahan & Silva 2008, after Kopf et al. 2007): a small rendered
//! image is upsampled to full size guided by full-size depth layers of the mesh boundary.
//!
//! - [`BoundaryRaster`] rasterises the boundary faces of a mesh on the CPU and keeps, per pixel,
//!   the first `k` depths along the pixel's ray (k = 1..=4) — the CPU equivalent of `k` depth-peeling
//!   passes. Depths are normalised to [0, 1] over the bounding sphere (ortho: distance from the
//!   eye plane in [R, 3R]; persp: distance along the view axis in [2R, 4R]); a pixel with fewer
//!   than `k` layers gets 1.0 in the missing ones (so background is the vector of ones).
//!   Coverage is decided at the pixel centre with exact 2-D orientation predicates and a
//!   top-left tie rule, so a pixel centre on an edge shared by two faces is counted once.
//! - [`upsample`] is the filter (eq. (3): `S_p = 1/k_p Σ_q I_q f(p, q) g(R_p, R_q)` over low-res
//!   samples `q`), one of:
//!   - `nearest`, `linear` (bilinear, clamp-to-edge);
//!   - `bilateral` (default): f is the bilinear tent over the 2×2 samples around `p` — the
//!     support of the linear interpolation it replaces, as the paper matches Ω to it — and g the
//!     Gaussian of eq. (4) on the distance between the sample's layer vector `R_q` (the layers at
//!     the low-res pixel centre) and the full-size guide at `p` extrapolated to `q` along its
//!     per-layer slopes (minmod of the one-sided differences to neighbours with the same number
//!     of crossings, so a slope never reaches across an edge). Where the guide is planar over
//!     the four samples g = 1 and the result is bilinear to rounding; across a depth edge the
//!     samples beyond it drop out. The distance is the cheapest alignment of the two layer
//!     lists (`range.rs`): a pair of crossings that one side has and the other lacks costs its
//!     own separation (a pair is born with zero separation where a ray grazes the boundary, and
//!     the image is continuous there), and crossings beyond the k kept are not charged. Across
//!     an edge, a sample whose colour continues the pixel's side (within σ_c on premultiplied
//!     RGBA) is kept. Where no sample matches the pixel's surface (every g < 0.9: a surface
//!     too oblique for the samples, a feature thinner than a low-res pixel) the pixel is
//!     bilinear; if less than 1e-3 of the weight is left, the 2r×2r window of `gauss` with the
//!     same range term decides.
//!   - `gauss`: the filter as first built here: a Gaussian spatial kernel of σ = Ω/2 full-res
//!     pixels over 2r×2r samples and g on the plain distance `‖R_p − R_q‖`, weights normalised
//!     in the log domain (a pixel whose samples all differ by many σ_r takes the best match).
//!
//!   σ_r's rule: it is in units of the depth normalisation above (1 = the bounding sphere's
//!   diameter 2R along the view axis), so it does not depend on the image size; a depth
//!   mismatch of σ_r (after extrapolation) keeps e^−½ of a sample's weight, 3.7 σ_r about 1e-3.
//!   The default 0.02 (k = 4 layers) was chosen on the 14 cube views of spx, blunt, post and
//!   comb at 8×, 4× and 2× (harness/examples/jbu_views.rs); the paper's 0.01 cuts too often on
//!   oblique faces, whose extrapolation error grows with the sample distance.
//!
//! Low-res and full-res images cover the same image-plane square (CONVENTIONS §2), so a
//! full-res pixel centre maps to low-res continuous coordinates by the ratio of pixel sizes.

use std::time::Instant;

use crate::camera::{Camera, View};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::Mesh;
use crate::plugin::{self, ParamInfo};

mod fast;
mod filter;
mod range;
mod raster;
mod wrapper;

pub use raster::{BoundaryRaster, DepthLayers};
pub use wrapper::{make, Jbu, LowSize, Spec, JBU, PREFIX};

/// Most depth layers a [`BoundaryRaster`] keeps.
pub const MAX_LAYERS: usize = 4;

/// How the low-res image is brought to full size.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Method {
    Nearest,
    Linear,
    #[default]
    Bilateral,
    Gauss,
}

impl Method {
    pub const ALL: [Method; 4] = [
        Method::Nearest,
        Method::Linear,
        Method::Bilateral,
        Method::Gauss,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Method::Nearest => "nearest",
            Method::Linear => "linear",
            Method::Bilateral => "bilateral",
            Method::Gauss => "gauss",
        }
    }
    /// Whether the method needs the depth layers.
    pub fn guided(self) -> bool {
        matches!(self, Method::Bilateral | Method::Gauss)
    }
}

/// Filter parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    pub method: Method,
    /// Depth layers in the range vector (1..=4; bilateral only).
    pub k: usize,
    /// σ of the Gaussian range kernel on normalised depth (bilateral only).
    pub sigma_r: f64,
    /// σ of the Gaussian colour-consistency kernel on premultiplied RGBA (bilateral only).
    pub sigma_c: f64,
    /// Low-res samples on each side of the point: `2·radius` per axis (bilateral only; 1 is the
    /// 2×2 bilinear footprint, 2 the 4×4 default; `gauss`, and `bilateral`'s fallback).
    pub radius: usize,
}

/// The filter's options, as `jbu:<renderer>@<size>,key=value` takes them: the one place their
/// defaults are written ([`Params::default`] is built from this table).
pub const PARAMS: &[ParamInfo] = &[
    ParamInfo {
        name: "method",
        default: "bilateral",
        doc: "nearest, linear, bilateral or gauss (see algorithms::render::jbu)",
    },
    ParamInfo {
        name: "k",
        default: "4",
        doc: "boundary depth layers of the guide, 1..4 (bilateral, gauss)",
    },
    ParamInfo {
        name: "sigma",
        default: "0.02",
        doc: "range sigma in units of the depth normalisation (1 = the bounding sphere's diameter along the view axis; bilateral, gauss)",
    },
    ParamInfo {
        name: "c",
        default: "0.1",
        doc: "colour-consistency sigma on premultiplied RGBA at depth edges (bilateral)",
    },
    ParamInfo {
        name: "r",
        default: "2",
        doc: "window radius in low-res pixels, 1..8: 2r x 2r samples (gauss; bilateral's fallback)",
    },
];

impl Default for Params {
    /// The defaults of [`PARAMS`].
    fn default() -> Self {
        // The table is a constant; tests/tests/renderers/jbu.rs checks every default parses.
        Params::read(&[]).expect("the documented defaults are valid")
    }
}

impl Params {
    /// Parameters from `KEY=VALUE` pairs (keys of [`PARAMS`]), the defaults for what is not
    /// given, checked; `Error::Input` names a bad key or value.
    pub fn read(given: &[(String, String)]) -> Result<Params> {
        let p = plugin::Params::new("jbu", PARAMS, given)?;
        Ok(Params {
            method: p.choice("method", &Method::ALL.map(|m| (m.name(), m)))?,
            k: p.usize_in("k", 1..=MAX_LAYERS)?,
            sigma_r: p.positive_f64("sigma")?,
            sigma_c: p.positive_f64("c")?,
            radius: p.usize_in("r", 1..=8)?,
        })
    }

    /// Parameters from a spec `method[:key=value]...` (keys of [`PARAMS`], `s` short for
    /// `sigma`), the defaults for what is not given, checked; e.g. `bilateral:k=2:s=0.01`.
    pub fn from_spec(spec: &str) -> Result<Params> {
        let mut it = spec.split(':');
        let mut given = vec![("method".to_string(), it.next().unwrap_or_default().to_string())];
        for o in it {
            let (k, v) = o
                .split_once('=')
                .ok_or_else(|| Error::Input(format!("jbu: '{o}' is not key=value")))?;
            let k = if k == "s" { "sigma" } else { k };
            given.push((k.to_string(), v.to_string()));
        }
        Params::read(&given)
    }

    /// Checks the ranges; `Error::Input` names the bad value.
    pub fn check(&self) -> Result<()> {
        if !(1..=MAX_LAYERS).contains(&self.k) {
            return Err(Error::Input(format!(
                "jbu: k={} must be 1..={MAX_LAYERS} depth layers",
                self.k
            )));
        }
        if !(self.sigma_r.is_finite() && self.sigma_r > 0.0) {
            return Err(Error::Input(format!(
                "jbu: sigma={} must be a positive number",
                self.sigma_r
            )));
        }
        if !(self.sigma_c.is_finite() && self.sigma_c > 0.0) {
            return Err(Error::Input(format!(
                "jbu: c={} must be a positive number",
                self.sigma_c
            )));
        }
        if !(1..=8).contains(&self.radius) {
            return Err(Error::Input(format!(
                "jbu: r={} must be 1..=8 low-res pixels",
                self.radius
            )));
        }
        Ok(())
    }
}

/// Upsamples `low` (rendered with `low_cam`) to the size of `full_cam`. `layers` are the depth
/// layers of the full image and of the low image (guided methods only; same `k`).
pub fn upsample(
    low: &Image,
    low_cam: &Camera,
    full_cam: &Camera,
    params: &Params,
    layers: Option<(&DepthLayers, &DepthLayers)>,
) -> Result<Image> {
    filter::upsample(low, low_cam, full_cam, params, layers, true)
}

/// [`upsample`] by the scalar definition of each filter (no fast paths): the yardstick the fast
/// path is tested and benchmarked against. Same result, bit for bit, for a finite guide.
pub fn upsample_scalar(
    low: &Image,
    low_cam: &Camera,
    full_cam: &Camera,
    params: &Params,
    layers: Option<(&DepthLayers, &DepthLayers)>,
) -> Result<Image> {
    filter::upsample(low, low_cam, full_cam, params, layers, false)
}

/// The paper's 14 viewpoints: the 8 corners and the 6 faces of a cube around the dataset
/// (Callahan & Silva §4), corners first.
pub fn cube_views() -> Vec<View> {
    let corner = (1.0f64 / 3.0).sqrt().asin().to_degrees();
    let mut v: Vec<View> = [1.0, -1.0]
        .into_iter()
        .flat_map(|e| (0..4).map(move |a| View::new(45.0 + 90.0 * a as f64, e * corner)))
        .collect();
    v.extend((0..4).map(|a| View::new(90.0 * a as f64, 0.0)));
    v.push(View::new(0.0, 90.0));
    v.push(View::new(0.0, -90.0));
    v
}

/// The low-res camera for `full`: same view and projection, `lw`×`lh` pixels over the same
/// image-plane square.
pub fn low_camera(mesh: &Mesh, full: &Camera, lw: u32, lh: u32) -> Camera {
    Camera::new(&mesh.bbox(), full.view, full.projection, lw, lh)
}

/// The filter with its boundary prepared for one mesh: the part of the JBU wrapper after the
/// low-res render, usable on its own (the harness filters one low-res image several ways).
pub struct Upsampler {
    pub params: Params,
    raster: Option<BoundaryRaster>,
}

/// An upsampled image and the time of its two stages.
pub struct Upsampled {
    pub image: Image,
    pub depth_ms: f64,
    pub filter_ms: f64,
}

impl Upsampler {
    pub fn new(params: Params) -> Result<Upsampler> {
        params.check()?;
        Ok(Upsampler {
            params,
            raster: None,
        })
    }

    /// Collects the boundary of `mesh` (bilateral only).
    pub fn prepare(&mut self, mesh: &Mesh) {
        self.raster = self
            .params
            .method
            .guided()
            .then(|| BoundaryRaster::new(mesh));
    }

    /// Upsamples `low` (rendered with `low_cam`) to `full_cam`'s size. A low image of the full
    /// size is returned as it is (factor 1: nothing to upsample).
    pub fn run(&self, low: &Image, low_cam: &Camera, full_cam: &Camera) -> Result<Upsampled> {
        if (low.width, low.height) == (full_cam.width, full_cam.height) {
            return Ok(Upsampled {
                image: low.clone(),
                depth_ms: 0.0,
                filter_ms: 0.0,
            });
        }
        let t0 = Instant::now();
        let layers = match (&self.raster, self.params.method.guided()) {
            (Some(r), true) => Some((
                r.layers(full_cam, self.params.k),
                r.layers(low_cam, self.params.k),
            )),
            (None, true) => return Err(Error::Internal("jbu: run before prepare".into())),
            _ => None,
        };
        let depth_ms = t0.elapsed().as_secs_f64() * 1e3;
        let t1 = Instant::now();
        let image = upsample(
            low,
            low_cam,
            full_cam,
            &self.params,
            layers.as_ref().map(|(a, b)| (a, b)),
        )?;
        Ok(Upsampled {
            image,
            depth_ms,
            filter_ms: t1.elapsed().as_secs_f64() * 1e3,
        })
    }
}
