//! VTK's unstructured-grid volume mappers as peers: `vtk-pt` (`vtkProjectedTetrahedraMapper`),
//! `vtk-raycast` (`vtkUnstructuredGridVolumeRayCastMapper`, Bunyk et al. 1997) and `vtk-zsweep`
//! (`vtkUnstructuredGridVolumeZSweepMapper`, Farias et al. 2000). They are peers like any other
//! (`docs/peers.md`), declared here rather than in a peers file: `vtk_peer.py` beside this file
//! is a client of the Python SDK (`peers/python/tetbench_peer.py`); both are compiled into the
//! binary and written into the peer's private directory, and run under the Python named by
//! `TETBENCH_VTK_PYTHON` (a Python with `vtk` and `numpy`).
//!
//! What had to change to follow the contract (the camera widened for VTK's ray grids, the
//! transfer function as VTK nodes, zero-volume cells dropped) is done by `vtk_peer.py` from the
//! protocol's scene and camera, and documented in `docs/vtk.md`.

use std::ffi::OsString;
use std::path::PathBuf;
use std::time::Duration;

use super::peer::{Launch, PeerFamily, PeerParam, PeerRenderer, PeerSpec};
use super::{Family, RenderOptions, Renderer, RendererInfo};
use crate::error::{Error, Result};
use crate::plugin::{ParamInfo, Params};

/// The environment variable naming a Python with `vtk` and `numpy`.
pub const PYTHON_VAR: &str = "TETBENCH_VTK_PYTHON";

/// The environment variable that sets the VTK peers' deadline per request, in seconds.
pub const TIMEOUT_VAR: &str = "TETBENCH_VTK_TIMEOUT_S";

/// Their deadline when [`TIMEOUT_VAR`] is not set: an hour, since VTK's ray caster has been
/// seen to take minutes to set up a 20M-tet mesh.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(3600);

/// The deadline of every request to a VTK peer ([`TIMEOUT_VAR`], else [`DEFAULT_TIMEOUT`]).
pub fn timeout() -> Result<Duration> {
    match std::env::var(TIMEOUT_VAR) {
        Err(_) => Ok(DEFAULT_TIMEOUT),
        Ok(v) => match v.trim().parse::<f64>() {
            Ok(t) if t.is_finite() && t > 0.0 && t <= 86_400.0 => Ok(Duration::from_secs_f64(t)),
            _ => Err(Error::Input(format!(
                "{TIMEOUT_VAR}={v}: expected seconds in (0, 86400]"
            ))),
        },
    }
}

/// How to enable the VTK peers (for `tetbench list` and error messages).
pub const HOW_TO_ENABLE: &str = "set TETBENCH_VTK_PYTHON to a Python with vtk and numpy, e.g. \
    `python3 -m venv ~/vtk-venv && ~/vtk-venv/bin/pip install \"vtk==9.*\" numpy` and \
    `export TETBENCH_VTK_PYTHON=~/vtk-venv/bin/python`";

const PEER_SOURCE: &str = include_str!("vtk_peer.py");
const SDK_SOURCE: &str = include_str!("../../../peers/python/tetbench_peer.py");

/// Registry entry for `vtk-pt`.
pub static VTK_PT: RendererInfo = RendererInfo {
    name: "vtk-pt",
    description: "VTK's vtkProjectedTetrahedraMapper (external, TETBENCH_VTK_PYTHON): \
                  Shirley-Tuchman averaging, per-vertex colour and opacity in bytes",
    sorts: &[],
    integrators: &["average"],
    family: Family::External,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "average",
    params: &[],
    // Measured by the registry-wide test (worst of its two views), ×1.5.
    max_rmse: &[("average", 1.8e-2)],
    make: |info, o| make(info, "pt", o),
};

/// The ray grid parameter of `vtk-raycast` and `vtk-zsweep`.
const GRID_PARAM: &[ParamInfo] = &[ParamInfo {
    name: "grid",
    default: "vtk",
    doc: "vtk (ImageSampleDistance 1, VTK's usual setting; its ray image resampled at our pixel \
          centres) or aligned (2W+1 rays a row: one ray exactly through each pixel centre, 4x the rays)",
}];

/// Registry entry for `vtk-raycast`.
pub static VTK_RAYCAST: RendererInfo = RendererInfo {
    name: "vtk-raycast",
    description: "VTK's Bunyk ray caster, vtkUnstructuredGridVolumeRayCastMapper (external, \
                  TETBENCH_VTK_PYTHON)",
    sorts: &[],
    integrators: &["preint", "partial"],
    family: Family::External,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "preint",
    params: GRID_PARAM,
    // Measured by the registry-wide test (worst of its two views), ×1.5.
    max_rmse: &[("preint", 4.9e-2), ("partial", 4.9e-2)],
    make: |info, o| make(info, "raycast", o),
};

/// Registry entry for `vtk-zsweep`.
pub static VTK_ZSWEEP: RendererInfo = RendererInfo {
    name: "vtk-zsweep",
    description: "VTK's vtkUnstructuredGridVolumeZSweepMapper (external, TETBENCH_VTK_PYTHON)",
    sorts: &[],
    integrators: &["preint", "partial"],
    family: Family::External,
    needs_gpu: false,
    default_sort: "",
    table_sorts: &[],
    default_integrator: "preint",
    params: GRID_PARAM,
    // Measured by the registry-wide test (worst of its two views), ×1.5.
    max_rmse: &[("preint", 0.118), ("partial", 0.118)],
    make: |info, o| make(info, "zsweep", o),
};

/// The family each VTK peer is taken by in the papers' tables: the PT mapper with the PT
/// renderers, the ray caster and ZSweep (which integrates each pixel's ray, cell by cell, in a
/// sweep) with the ray casters.
pub fn family(name: &str) -> Option<PeerFamily> {
    match name {
        "vtk-pt" => Some(PeerFamily::Pt),
        "vtk-raycast" | "vtk-zsweep" => Some(PeerFamily::RayCasting),
        _ => None,
    }
}

/// Whether the VTK peers can run: the Python they would use, or why not.
pub fn python() -> Result<PathBuf> {
    match std::env::var_os(PYTHON_VAR) {
        None => Err(Error::Input(format!(
            "the VTK renderers are not enabled: {HOW_TO_ENABLE}"
        ))),
        Some(p) if p.is_empty() => Err(Error::Input(format!(
            "{PYTHON_VAR} is empty: {HOW_TO_ENABLE}"
        ))),
        Some(p) => {
            let p = PathBuf::from(p);
            // A bare command name (`python3`) is looked up on PATH when started.
            if p.components().count() > 1 && !p.exists() {
                return Err(Error::Input(format!(
                    "{PYTHON_VAR}={}: no such file ({HOW_TO_ENABLE})",
                    p.display()
                )));
            }
            Ok(p)
        }
    }
}

/// The peer spec of one mapper: `$TETBENCH_VTK_PYTHON vtk_peer.py MAPPER`, started in its
/// private directory beside the SDK.
pub fn spec(info: &RendererInfo, mapper: &str) -> Result<PeerSpec> {
    let python = python().map_err(|e| Error::Input(format!("{}: {e}", info.name)))?;
    Ok(PeerSpec {
        name: info.name.to_string(),
        description: info.description.to_string(),
        family: family(info.name).unwrap_or(PeerFamily::Other),
        integrators: info.integrators.iter().map(|s| s.to_string()).collect(),
        params: info
            .params
            .iter()
            .map(|p| PeerParam {
                name: p.name.into(),
                default: p.default.into(),
                doc: p.doc.into(),
            })
            .collect(),
        timeout: timeout().map_err(|e| Error::Input(format!("{}: {e}", info.name)))?,
        launch: Launch {
            program: python.into_os_string(),
            args: vec![OsString::from("vtk_peer.py"), OsString::from(mapper)],
            cwd: None,
            env: Vec::new(),
            files: vec![("vtk_peer.py", PEER_SOURCE), ("tetbench_peer.py", SDK_SOURCE)],
        },
        origin: "built in (render/vtk.rs)".into(),
    })
}

/// The spec of the VTK peer named `name` (`None` for other names).
pub fn spec_by_name(name: &str) -> Option<Result<PeerSpec>> {
    let (info, mapper) = match name {
        "vtk-pt" => (&VTK_PT, "pt"),
        "vtk-raycast" => (&VTK_RAYCAST, "raycast"),
        "vtk-zsweep" => (&VTK_ZSWEEP, "zsweep"),
        _ => return None,
    };
    Some(spec(info, mapper))
}

fn make(info: &RendererInfo, mapper: &str, o: &RenderOptions) -> Result<Box<dyn Renderer>> {
    let p = Params::new(info.name, info.params, &o.params)?;
    // `vtk-pt` takes no `grid`; the ray-cast and ZSweep mappers do.
    if info.params.iter().any(|q| q.name == "grid") {
        p.choice("grid", &[("vtk", ()), ("aligned", ())])?;
    }
    // Checked here, so that a command or an experiment naming a VTK peer fails before any work.
    Ok(Box::new(PeerRenderer::new(spec(info, mapper)?, o)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_parameters_and_grids_are_refused() {
        let bad = |name: &str, k: &str, v: &str| {
            let o = RenderOptions {
                params: vec![(k.into(), v.into())],
                ..Default::default()
            };
            match crate::render::make(name, &o) {
                Err(e) => e.to_string(),
                Ok(_) => String::new(),
            }
        };
        assert!(bad("vtk-pt", "grid", "aligned").contains("unknown parameter 'grid'"));
        assert!(bad("vtk-raycast", "grid", "fine").contains("grid=fine: expected one of vtk, aligned"));
        assert!(bad("vtk-raycast", "isd", "1").contains("unknown parameter 'isd'"));
    }
}
