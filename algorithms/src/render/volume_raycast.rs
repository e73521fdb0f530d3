//! `volume-raycast`: ray casting the regular volume that a lattice mesh's vertices sample, with
//! the BCC paper's reconstruction schemes (§3; [`crate::bcc::recon`]): trilinear on a CC lattice
//! (`cc5`, `cc6`: the tets are not used, only the grid of samples), `bil`, `bilspat`, `bary`,
//! `shtril` on a `bcc` lattice. Lattice meshes only (their `field_data["lattice"]`), orthographic
//! views only.
//!
//! Rays are clipped to the lattice's (primary) box and sampled every `step` (world units; `bil`
//! samples where the ray meets the lattice planes instead); each piece between samples is
//! integrated by the chosen integrator. The volume is the box: `L` is the box's diagonal, not
//! the mesh's (CONVENTIONS §1 takes the mesh's; a `bcc` mesh's secondary grid reaches half a
//! cell beyond the box, there only to reconstruct near its faces), so that volumes of one box
//! sampled on different lattices are integrated alike. On a CC lattice the two are the same.
//!
//! A `bcc` mesh leaves out the 8 corners of its secondary grid (no tet uses them); the volume
//! takes the nearest primary corner's sample there, which only rays grazing the box's corners
//! could reach.

use std::time::Instant;

use super::{
    ms_since, Description, Family, Frame, FrameTimes, RenderOptions, Renderer, RendererInfo,
};
use crate::bcc::recon::{self, BccVolume, CcVolume, Sampling, Scheme, Volume};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::bcc::lattice::{Lattice, LatticeKind};
use crate::mesh::Mesh;
use crate::optics::{self, Integrator, INTEGRATORS};
use crate::plugin::{ParamInfo, Params};
use crate::tf::{ScalarMap, TransferFunction};

/// The parameters, with their defaults.
const PARAMS: &[ParamInfo] = &[
    ParamInfo {
        name: "scheme",
        default: "auto",
        doc: "tril (cc5, cc6), bil, bilspat, bary, shtril (bcc); auto: tril on CC, bary on BCC",
    },
    ParamInfo {
        name: "step",
        default: "auto",
        doc: "world distance between samples along a ray; auto: half the CC spacing of the same information (CC h/2, BCC h/(2*sqrt 2))",
    },
];

pub static VOLUME_RAYCAST: RendererInfo = RendererInfo {
    name: "volume-raycast",
    description: "ray casting the regular volume of a lattice mesh's samples with the BCC paper's reconstruction schemes (lattice meshes only, orthographic)",
    sorts: &[],
    integrators: &INTEGRATORS,
    family: Family::Volume,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "exact",
    params: PARAMS,
    // Measured by the registry-wide test (worst of its two views), ×1.5.
    max_rmse: &[("average", 1.8e-2), ("partial", 1.8e-2), ("preint", 1.8e-2), ("exact", 1.8e-2)],
    make: |_, o| Ok(Box::new(VolumeRaycast::new(o)?)),
};

/// The regular volume built from the mesh's samples.
enum Built {
    Cc(CcVolume),
    Bcc(Box<BccVolume>),
}

pub struct VolumeRaycast {
    integrator: String,
    /// `None`: chosen by the lattice (`auto`).
    scheme: Option<Scheme>,
    /// `None`: from the lattice (`auto`).
    step: Option<f64>,
    prepared: Option<Prepared>,
}

struct Prepared {
    volume: Built,
    scheme: Scheme,
    step: f64,
    map: ScalarMap,
    integ: Box<dyn Integrator>,
    diag: f64,
}

impl VolumeRaycast {
    pub fn new(o: &RenderOptions) -> Result<VolumeRaycast> {
        let p = Params::new("renderer 'volume-raycast'", PARAMS, &o.params)?;
        // `auto`: chosen by the lattice.
        let schemes: Vec<(&str, Option<Scheme>)> = std::iter::once(("auto", None))
            .chain(Scheme::ALL.into_iter().map(|s| (s.name(), Some(s))))
            .collect();
        let scheme = p.choice("scheme", &schemes)?;
        let step = match p.text("step") {
            "auto" => None,
            _ => Some(p.positive_f64("step")?),
        };
        Ok(VolumeRaycast {
            integrator: o.integrator.clone().unwrap_or_else(|| "exact".into()),
            scheme,
            step,
            prepared: None,
        })
    }
}

/// The diagonal of the lattice's (primary) box.
fn box_diagonal(l: &Lattice) -> f64 {
    let n = l.n.map(|x| x.saturating_sub(1) as f64);
    (l.spacing * crate::glam::DVec3::from_array(n)).length()
}

/// The CC volume of a CC lattice mesh: its vertices are the grid, in the grid's order.
fn cc_volume(l: &Lattice, mesh: &Mesh) -> CcVolume {
    CcVolume {
        n: l.n,
        origin: l.origin,
        h: l.spacing,
        values: mesh.scalars().to_vec(),
    }
}

/// The BCC volume of a `bcc` mesh: the primary samples come first, then the secondary ones
/// without the 8 corners of their grid (filled from the nearest primary corner).
fn bcc_volume(l: &Lattice, mesh: &Mesh) -> BccVolume {
    let n = l.n;
    let s = mesh.scalars();
    let np = n[0] * n[1] * n[2];
    let primary = s[..np].to_vec();
    let m = n.map(|x| x + 1);
    let mut rest = s[np..].iter();
    let mut secondary = Vec::with_capacity(m[0] * m[1] * m[2]);
    for k in 0..m[2] {
        for j in 0..m[1] {
            for i in 0..m[0] {
                let ends = [(i, 0), (j, 1), (k, 2)];
                if ends.iter().all(|&(x, a)| x == 0 || x == m[a] - 1) {
                    let c = |x: usize, a: usize| if x == 0 { 0 } else { n[a] - 1 };
                    secondary.push(primary[c(i, 0) + n[0] * (c(j, 1) + n[1] * c(k, 2))]);
                } else {
                    secondary.push(rest.next().copied().unwrap_or(0.0));
                }
            }
        }
    }
    BccVolume::from_samples(n, l.origin, l.spacing, primary, secondary)
}

impl Renderer for VolumeRaycast {
    fn describe(&self) -> Description {
        Description::cpu("volume-raycast", "", &self.integrator)
    }
    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        let l = Lattice::of_mesh(mesh, "renderer 'volume-raycast'")?;
        let cc = l.kind != LatticeKind::Bcc;
        let scheme = match self.scheme {
            None if cc => Scheme::Trilinear,
            None => Scheme::Barycentric,
            Some(s) if (s == Scheme::Trilinear) == cc => s,
            Some(s) => {
                return Err(Error::Input(format!(
                    "renderer 'volume-raycast': scheme {} reconstructs on {}, and this mesh is a {} lattice",
                    s.name(),
                    if s == Scheme::Trilinear { "CC (cc5, cc6)" } else { "BCC" },
                    if cc { "CC" } else { "BCC" }
                )))
            }
        };
        let h = l.spacing.min_element();
        let step = self.step.unwrap_or(if cc {
            h / 2.0
        } else {
            h / (2.0 * std::f64::consts::SQRT_2)
        });
        let volume = if cc {
            Built::Cc(cc_volume(&l, mesh))
        } else {
            Built::Bcc(Box::new(bcc_volume(&l, mesh)))
        };
        self.prepared = Some(Prepared {
            volume,
            scheme,
            step,
            map: tf.scalar_map(mesh.scalar_range()),
            integ: optics::integrator(&self.integrator, tf)?,
            diag: box_diagonal(&l),
        });
        Ok(())
    }
    fn render(&mut self, _mesh: &Mesh, camera: &Camera) -> Result<Frame> {
        let p = self.prepared.as_ref().ok_or_else(|| {
            Error::Internal("volume-raycast: render before prepare".into())
        })?;
        let (vol, samples) = match &p.volume {
            Built::Cc(v) => (Volume::Cc(v), v.samples()),
            Built::Bcc(v) => (Volume::Bcc(v), v.samples()),
        };
        let sampling = Sampling {
            map: p.map,
            integ: p.integ.as_ref(),
            step: p.step,
            diag: p.diag,
        };
        let t0 = Instant::now();
        let image = recon::raycast(vol, p.scheme, camera, sampling)?;
        let ms = ms_since(t0);
        Ok(Frame {
            image,
            times: FrameTimes {
                draw_ms: ms,
                total_ms: ms,
                ..Default::default()
            },
            counters: vec![("samples", samples as f64), ("step", p.step)],
        })
    }
}
