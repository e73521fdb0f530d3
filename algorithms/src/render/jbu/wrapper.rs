//! `jbu:<renderer>@<low size>[,option=value...]`: any registered renderer run at a low
//! resolution and brought to the requested size by joint bilateral upsampling (see
//! [`crate::render::jbu`]).
//!
//! Name syntax:
//! - `<renderer>`: a registered renderer (`raycast`, `cpu-pt`, ...; not another `jbu:`). Its sort
//!   and integrator come from the `RenderOptions` as for the renderer itself.
//! - `<low size>`: `N` (the longer side of the low image is N pixels, the other side keeps the
//!   full image's aspect ratio) or `WxH`. It must not exceed the full image; equal to it, the
//!   inner image is returned unchanged.
//! - options, comma-separated after the size: `method`, `k`, `sigma`, `c`, `r`, with their
//!   defaults and meaning in [`crate::render::jbu::PARAMS`] (what `tetbench list` prints).
//!
//! Examples: `jbu:raycast@128`, `jbu:cpu-pt@256x256`, `jbu:raycast@128,method=linear`,
//! `jbu:raycast@256,k=4,sigma=0.02`.
//!
//! Frame times: `project_ms`, `sort_ms`, `draw_ms`, `readback_ms` are the inner renderer's at
//! the low size; `total_ms` = `low_ms` + `depth_ms` + `filter_ms` (also given as counters),
//! where `low_ms` is the wall time of the inner render.

use std::time::Instant;

use super::{low_camera, Params, Upsampler};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::render::{
    ms_since, Description, Family, Frame, FrameTimes, Memory, RenderOptions, Renderer,
    RendererInfo,
};
use crate::tf::TransferFunction;

/// Registry line describing the pattern (for `tetbench list`); a real wrapper is made from a
/// full name by [`crate::render::make`].
pub static JBU: RendererInfo = RendererInfo {
    name: "jbu:<renderer>@<size>",
    description: "joint bilateral upsampling of <renderer> rendered at <size> (N or WxH); \
                  options ,key=value of the params below",
    sorts: &[],
    integrators: &["as <renderer>"],
    family: Family::Wrapper,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "as <renderer>",
    // Given in the name (`jbu:raycast@128,k=2`); `--param` keys go to the inner renderer.
    params: super::PARAMS,
    // The pattern has no integrators of its own (`jbu` tests it around every renderer).
    max_rmse: &[],
    make: |_, _| {
        Err(Error::Input(
            "jbu: give the inner renderer and low size, e.g. jbu:raycast@128".into(),
        ))
    },
};

/// The prefix of wrapper names.
pub const PREFIX: &str = "jbu:";

/// Low-res size: the longer side, or both sides.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LowSize {
    Long(u32),
    Exact(u32, u32),
}

impl LowSize {
    /// The low image size for a full image of `w`×`h`.
    pub fn resolve(self, w: u32, h: u32) -> (u32, u32) {
        match self {
            LowSize::Exact(a, b) => (a, b),
            LowSize::Long(n) => {
                let scale =
                    |x: u32, long: u32| ((x as f64 * n as f64 / long as f64).round() as u32).max(1);
                if w >= h {
                    (n, scale(h, w))
                } else {
                    (scale(w, h), n)
                }
            }
        }
    }
}

/// A parsed wrapper name.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    pub inner: String,
    pub low: LowSize,
    pub params: Params,
}

impl Spec {
    /// Parses a full name `jbu:<renderer>@<size>[,opt=value...]`.
    pub fn parse(name: &str) -> Result<Spec> {
        let bad = |why: String| {
            Error::Input(format!(
                "renderer '{name}': {why} (expected jbu:<renderer>@<N|WxH>[,method=bilateral|gauss|linear|nearest][,k=1..4][,sigma=F][,c=F][,r=N])"
            ))
        };
        let body = name
            .strip_prefix(PREFIX)
            .ok_or_else(|| bad("not a jbu: name".into()))?;
        let (inner, rest) = body
            .split_once('@')
            .ok_or_else(|| bad("no low-res size after '@'".into()))?;
        if inner.is_empty() {
            return Err(bad("no inner renderer".into()));
        }
        if inner.starts_with(PREFIX) {
            return Err(bad("jbu: wrappers do not nest".into()));
        }
        let mut parts = rest.split(',');
        let size = parts.next().unwrap_or("").trim();
        let num = |s: &str| -> Option<u32> { s.trim().parse::<u32>().ok().filter(|&v| v > 0) };
        let low = match size.split_once(['x', 'X']) {
            Some((a, b)) => match (num(a), num(b)) {
                (Some(a), Some(b)) => LowSize::Exact(a, b),
                _ => return Err(bad(format!("bad low-res size '{size}'"))),
            },
            None => {
                LowSize::Long(num(size).ok_or_else(|| bad(format!("bad low-res size '{size}'")))?)
            }
        };
        if matches!(low, LowSize::Long(n) | LowSize::Exact(n, _) | LowSize::Exact(_, n) if n > 16384)
        {
            return Err(bad(format!("low-res size '{size}' above 16384")));
        }
        let mut given = Vec::new();
        for opt in parts {
            let (k, v) = opt
                .split_once('=')
                .ok_or_else(|| bad(format!("option '{opt}' is not key=value")))?;
            given.push((k.trim().to_string(), v.trim().to_string()));
        }
        let params = Params::read(&given).map_err(|e| bad(e.to_string()))?;
        crate::render::info(inner).map_err(|e| Error::Input(format!("renderer '{name}': {e}")))?;
        Ok(Spec {
            inner: inner.to_string(),
            low,
            params,
        })
    }
}

/// Makes the wrapper from a full `jbu:` name (checks the options against the inner renderer).
pub fn make(name: &str, opts: &RenderOptions) -> Result<Box<dyn Renderer>> {
    let spec = Spec::parse(name)?;
    let inner = crate::render::make(&spec.inner, opts)?;
    Ok(Box::new(Jbu::new(name, spec, inner)?))
}

/// The wrapper renderer.
pub struct Jbu {
    name: String,
    spec: Spec,
    inner: Box<dyn Renderer>,
    up: Upsampler,
}

impl Jbu {
    pub fn new(name: &str, spec: Spec, inner: Box<dyn Renderer>) -> Result<Jbu> {
        Ok(Jbu {
            name: name.to_string(),
            up: Upsampler::new(spec.params)?,
            spec,
            inner,
        })
    }
    pub fn spec(&self) -> &Spec {
        &self.spec
    }
}

impl Renderer for Jbu {
    fn describe(&self) -> Description {
        Description {
            name: self.name.clone(),
            ..self.inner.describe()
        }
    }
    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        self.inner.prepare(mesh, tf)?;
        self.up.prepare(mesh);
        Ok(())
    }
    fn render(&mut self, mesh: &Mesh, camera: &Camera) -> Result<Frame> {
        let (w, h) = (camera.width, camera.height);
        let (lw, lh) = self.spec.low.resolve(w, h);
        if lw > w || lh > h {
            return Err(Error::Input(format!(
                "renderer '{}': low-res size {lw}x{lh} is larger than the image {w}x{h}",
                self.name
            )));
        }
        let low_cam = low_camera(mesh, camera, lw, lh);
        let t0 = Instant::now();
        let low = self.inner.render(mesh, &low_cam)?;
        let low_ms = ms_since(t0);
        let up = self.up.run(&low.image, &low_cam, camera)?;
        let mut counters = vec![
            ("low_ms", low_ms),
            ("depth_ms", up.depth_ms),
            ("filter_ms", up.filter_ms),
            ("low_width", lw as f64),
            ("low_height", lh as f64),
        ];
        counters.extend(low.counters);
        Ok(Frame {
            image: up.image,
            times: FrameTimes {
                total_ms: low_ms + up.depth_ms + up.filter_ms,
                ..low.times
            },
            counters,
        })
    }

    fn memory(&self) -> Memory {
        Memory {
            gpu_bytes: self.inner.memory().gpu_bytes,
            external_bytes: None,
        }
    }
}
