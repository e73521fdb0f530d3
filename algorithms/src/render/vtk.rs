//! VTK's unstructured-grid volume mappers as peers: `vtk-pt` (`vtkProjectedTetrahedraMapper`),
//! `vtk-raycast` (`vtkUnstructuredGridVolumeRayCastMapper`, Bunyk et al. 1997) and `vtk-zsweep`
//! (`vtkUnstructuredGridVolumeZSweepMapper`, Farias et al. 2000). Family "external": they run in
//! a helper process, `vtk_peer.py` beside this file (compiled into the binary and written to a
//! private temporary directory), under the Python named by `TETBENCH_VTK_PYTHON`.
//!
//! **Contract.** The scene goes over in tetbench's terms, made VTK's here:
//! - positions centred on the bounding box (CONVENTIONS §1), scalars already mapped to the
//!   transfer function's `s`; cells with zero volume (`|V| < 1e-14·L³`) are dropped, because
//!   VTK's Bunyk ray caster crashes on them (counter `dropped_cells`; they hold no optical depth);
//! - the transfer function as a colour node and an opacity node at every point (VTK's ray-cast
//!   integrators read opacity only at colour nodes), opacity `τ/τ_max` with
//!   `ScalarOpacityUnitDistance = L/τ_max`, so VTK's attenuation `opacity / unit distance` is our
//!   `τ/L` per world length (§1, §4);
//! - the camera of §2 (ortho: parallel scale `H·p/2`; persp: eye at `3R`, vertical view angle
//!   `2·atan(H·p/2 / 3R)`). The ray-cast and ZSweep mappers cast `N = ⌊W / ImageSampleDistance⌋`
//!   rays a row whose cells are found at viewport fraction `k/N` and whose image is drawn with
//!   texel centres on the viewport edges (fraction `k/(N−1)`); the camera is therefore widened by
//!   `N/(N−1)` and shifted by half a sample (window centre `(1/N_x, 1/N_y)`), which puts VTK's
//!   linear reconstruction of its ray image exactly on our pixel centres. With `grid=aligned`,
//!   `N = 2W + 1`, and every pixel centre reads one ray exactly (4× the rays; exact in x and y
//!   for square images, in x for others).
//!
//! **Measurements.** `draw_ms` is VTK's `Render()` of the frame and `readback_ms` the download of
//! the float colour target, both timed inside the helper (no Python start-up, no file transfer).
//! VTK's first render (the PT mapper draws nothing on it) happens in `prepare` and, for a new
//! image size, once before the timed frame (`warmup_ms`). Memory is the helper's peak resident
//! set ([`Renderer::external_bytes`]).

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use serde_json::{json, Value};

use super::{Family, Frame, FrameTimes, RenderOptions, Renderer, RendererInfo};
use crate::camera::{Camera, Projection};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::mesh::Mesh;
use crate::plugin::ParamInfo;
use crate::tf::TransferFunction;

/// The environment variable naming a Python with `vtk` and `numpy`.
pub const PYTHON_VAR: &str = "TETBENCH_VTK_PYTHON";

/// How to enable the VTK peers (for `tetbench list` and error messages).
pub const HOW_TO_ENABLE: &str = "set TETBENCH_VTK_PYTHON to a Python with vtk and numpy, e.g. \
    `python3 -m venv ~/vtk-venv && ~/vtk-venv/bin/pip install \"vtk==9.*\" numpy` and \
    `export TETBENCH_VTK_PYTHON=~/vtk-venv/bin/python`";

const PEER_SOURCE: &str = include_str!("vtk_peer.py");

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
    make: |o| VtkPeer::make(Mapper::Pt, o),
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
    make: |o| VtkPeer::make(Mapper::Raycast, o),
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
    make: |o| VtkPeer::make(Mapper::Zsweep, o),
};

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

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mapper {
    Pt,
    Raycast,
    Zsweep,
}

impl Mapper {
    fn key(self) -> &'static str {
        match self {
            Mapper::Pt => "pt",
            Mapper::Raycast => "raycast",
            Mapper::Zsweep => "zsweep",
        }
    }
    fn name(self) -> &'static str {
        match self {
            Mapper::Pt => "vtk-pt",
            Mapper::Raycast => "vtk-raycast",
            Mapper::Zsweep => "vtk-zsweep",
        }
    }
}

/// The ray grid of the ray-cast and ZSweep mappers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Grid {
    /// `ImageSampleDistance = 1`, VTK's usual setting: one ray a pixel, resampled.
    Vtk,
    /// `2W + 1` rays a row: one ray exactly through each pixel centre.
    Aligned,
}

pub struct VtkPeer {
    mapper: Mapper,
    integrator: &'static str,
    grid: Grid,
    helper: Option<Helper>,
    device: String,
    dropped: usize,
    peak_rss: u64,
}

impl VtkPeer {
    fn make(mapper: Mapper, o: &RenderOptions) -> Result<Box<dyn Renderer>> {
        let mut grid = Grid::Vtk;
        for (k, v) in &o.params {
            match (mapper, k.as_str()) {
                (Mapper::Raycast | Mapper::Zsweep, "grid") => {
                    grid = match v.as_str() {
                        "vtk" => Grid::Vtk,
                        "aligned" => Grid::Aligned,
                        _ => {
                            return Err(Error::Input(format!(
                                "{}: parameter grid={v}: expected vtk or aligned",
                                mapper.name()
                            )))
                        }
                    }
                }
                _ => {
                    return Err(Error::Input(format!(
                        "{}: unknown parameter '{k}' (known: {})",
                        mapper.name(),
                        if mapper == Mapper::Pt { "none" } else { "grid" }
                    )))
                }
            }
        }
        let integrator = match (mapper, o.integrator.as_deref()) {
            (Mapper::Pt, _) => "average",
            (_, Some("partial")) => "partial",
            _ => "preint",
        };
        // Checked here, so that a command or an experiment naming a VTK peer fails before any work.
        python().map_err(|e| Error::Input(format!("{}: {e}", mapper.name())))?;
        Ok(Box::new(VtkPeer {
            mapper,
            integrator,
            grid,
            helper: None,
            device: String::new(),
            dropped: 0,
            peak_rss: 0,
        }))
    }

    /// The camera of CONVENTIONS §2 in VTK's terms, in the centred frame, and the ray count.
    fn vtk_camera(&self, cam: &Camera) -> (Value, u64) {
        let (w, h) = (cam.width.max(1), cam.height.max(1));
        let r = cam.radius.max(f64::MIN_POSITIVE);
        let half_h = 0.5 * h as f64 * cam.pixel;
        let (isd, nx, ny) = match (self.mapper, self.grid) {
            (Mapper::Pt, _) => (1.0f32, w, h),
            (_, Grid::Vtk) => (1.0f32, w, h),
            (_, Grid::Aligned) => {
                let isd = aligned_isd(w);
                (isd, rays_across(w, isd), rays_across(h, isd))
            }
        };
        // Ray grids: widen by N/(N−1); the ray caster's rays sit at k/N, so it is also shifted
        // by half a sample; ZSweep's sit at (k + ½)/N and need no shift (module docs).
        let (nxf, nyf) = (nx.max(2) as f64, ny.max(2) as f64);
        let (scale, center) = match self.mapper {
            Mapper::Pt => (1.0, [0.0, 0.0]),
            Mapper::Raycast => (nyf / (nyf - 1.0), [1.0 / nxf, 1.0 / nyf]),
            Mapper::Zsweep => (nyf / (nyf - 1.0), [0.0, 0.0]),
        };
        let half_v = half_h * scale;
        let (position, parallel, angle, clip) = match cam.projection {
            Projection::Ortho => (2.0 * r * cam.to_eye, true, 0.0, [0.25 * r, 3.75 * r]),
            Projection::Persp => (
                cam.eye(),
                false,
                2.0 * (half_v / (3.0 * r)).atan().to_degrees(),
                [0.5 * r, 4.5 * r],
            ),
        };
        let v = |p: DVec3| [p.x, p.y, p.z];
        (
            json!({
                "width": w, "height": h,
                "focal_point": [0.0, 0.0, 0.0],
                "position": v(position),
                "view_up": v(cam.up),
                "parallel": parallel,
                "parallel_scale": half_v,
                "view_angle": angle,
                "window_center": center,
                "clipping_range": clip,
                "image_sample_distance": isd,
            }),
            nx as u64 * ny as u64,
        )
    }
}

/// Rays across `size` pixels at image sample distance `isd`, as VTK computes it
/// (`static_cast<int>(size / ImageSampleDistance)` in float).
fn rays_across(size: u32, isd: f32) -> u32 {
    (size as f32 / isd) as u32
}

/// The largest f32 sample distance that gives `2W + 1` rays across `W` pixels.
fn aligned_isd(w: u32) -> f32 {
    let target = 2 * w + 1;
    let mut isd = w as f32 / target as f32;
    while rays_across(w, isd) < target {
        isd = f32::from_bits(isd.to_bits() - 1);
    }
    isd
}

impl Renderer for VtkPeer {
    fn name(&self) -> String {
        self.mapper.name().to_string()
    }
    fn integrator_name(&self) -> String {
        self.integrator.to_string()
    }
    fn device(&self) -> String {
        if self.device.is_empty() {
            "vtk".to_string()
        } else {
            self.device.clone()
        }
    }
    fn external_bytes(&self) -> Option<u64> {
        Some(self.peak_rss)
    }

    fn prepare(&mut self, mesh: &Mesh, tf: &TransferFunction) -> Result<()> {
        if self.helper.is_none() {
            let (helper, hello) = Helper::start(self.mapper.name())?;
            self.device = format!(
                "vtk {} / {} / {}",
                hello["vtk"].as_str().unwrap_or("?"),
                hello["gl"].as_str().unwrap_or("?"),
                hello["window"].as_str().unwrap_or("?")
            );
            self.helper = Some(helper);
        }
        let helper = self.helper.as_ref().expect("started above");
        // Centred positions, s per vertex, the cells that have a volume.
        let c = mesh.bbox().center();
        let l = mesh.diagonal();
        let map = tf.scalar_map(mesh.scalar_range());
        let eps = 1e-14 * l * l * l;
        let mut points = Vec::with_capacity(mesh.num_vertices() * 24);
        for p in mesh.positions() {
            for x in (*p - c).to_array() {
                points.extend_from_slice(&x.to_le_bytes());
            }
        }
        let mut scalars = Vec::with_capacity(mesh.num_vertices() * 8);
        for &v in mesh.scalars() {
            scalars.extend_from_slice(&map.s(v).to_le_bytes());
        }
        let mut tets = Vec::with_capacity(mesh.num_tets() * 32);
        self.dropped = 0;
        for (t, &vol) in mesh.tets().iter().zip(mesh.volumes()) {
            if vol.abs() < eps || vol == 0.0 {
                self.dropped += 1;
                continue;
            }
            for &i in t {
                tets.extend_from_slice(&(i as i64).to_le_bytes());
            }
        }
        helper.write("points.f64", &points)?;
        helper.write("scalars.f64", &scalars)?;
        helper.write("tets.i64", &tets)?;
        // τ → opacity τ/τ_max with unit distance L/τ_max (module docs).
        let tau_max = tf.max_tau();
        let (norm, unit) = if tau_max > 0.0 && l > 0.0 {
            (1.0 / tau_max, l / tau_max)
        } else {
            (0.0, l.max(f64::MIN_POSITIVE))
        };
        let nodes: Vec<Value> = tf
            .points
            .iter()
            .map(|p| json!({"s": p.s, "rgb": p.rgb, "opacity": (p.tau * norm).min(1.0)}))
            .collect();
        let warm = Camera::new(
            &mesh.bbox(),
            crate::camera::View::new(0.0, 0.0),
            Projection::Ortho,
            64,
            64,
        );
        let warmup = self.vtk_camera(&warm).0;
        let helper = self.helper.as_mut().expect("started above");
        let reply = helper.call(&json!({
            "cmd": "prepare",
            "mapper": self.mapper.key(),
            "integrator": self.integrator,
            "tf": nodes,
            "unit_distance": unit,
            "warmup": warmup,
        }))?;
        self.peak_rss = reply["peak_rss_bytes"].as_u64().unwrap_or(0);
        Ok(())
    }

    fn render(&mut self, _mesh: &Mesh, camera: &Camera) -> Result<Frame> {
        let (cam, rays) = self.vtk_camera(camera);
        let helper = self
            .helper
            .as_mut()
            .ok_or_else(|| Error::Internal(format!("{}: render before prepare", self.mapper.name())))?;
        let reply = helper.call(&json!({"cmd": "render", "camera": cam}))?;
        let (w, h) = (camera.width, camera.height);
        let bytes = helper.read("image.f32")?;
        let n = w as usize * h as usize;
        if bytes.len() != n * 16 {
            return Err(Error::Internal(format!(
                "{}: the helper's image has {} bytes, expected {}",
                self.mapper.name(),
                bytes.len(),
                n * 16
            )));
        }
        let mut image = Image::new(w, h);
        for (px, chunk) in image.pixels.iter_mut().zip(bytes.chunks_exact(16)) {
            for (c, b) in px.iter_mut().zip(chunk.chunks_exact(4)) {
                *c = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
        }
        let num = |k: &str| reply[k].as_f64().unwrap_or(0.0);
        self.peak_rss = self
            .peak_rss
            .max(reply["peak_rss_bytes"].as_u64().unwrap_or(0));
        let (draw_ms, readback_ms) = (num("draw_ms"), num("readback_ms"));
        let mut counters = vec![
            ("dropped_cells", self.dropped as f64),
            ("helper_peak_rss_bytes", self.peak_rss as f64),
            ("warmup_ms", num("warmup_ms")),
        ];
        if self.mapper != Mapper::Pt {
            counters.push(("rays", rays as f64));
        }
        Ok(Frame {
            image,
            times: FrameTimes {
                draw_ms,
                readback_ms,
                total_ms: draw_ms + readback_ms,
                ..Default::default()
            },
            counters,
        })
    }
}

/// The helper process and its private directory.
struct Helper {
    name: &'static str,
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    dir: PathBuf,
}

static NEXT_DIR: AtomicU64 = AtomicU64::new(0);

impl Helper {
    /// Starts `$TETBENCH_VTK_PYTHON vtk_peer.py DIR` and waits for VTK to load (`hello`).
    fn start(name: &'static str) -> Result<(Helper, Value)> {
        let python = python().map_err(|e| Error::Input(format!("{name}: {e}")))?;
        let dir = std::env::temp_dir().join(format!(
            "tetbench-vtk-{}-{}",
            std::process::id(),
            NEXT_DIR.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let script = dir.join("vtk_peer.py");
        std::fs::write(&script, PEER_SOURCE).map_err(|e| Error::io(&script, e))?;
        let log = dir.join("stderr.log");
        let err = std::fs::File::create(&log).map_err(|e| Error::io(&log, e))?;
        let spawned = Command::new(&python)
            .arg(&script)
            .arg(&dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(err)
            .spawn();
        let mut child = match spawned {
            Ok(c) => c,
            Err(e) => {
                let _ = std::fs::remove_dir_all(&dir);
                return Err(Error::Input(format!(
                    "{name}: cannot start {PYTHON_VAR}={}: {e}",
                    python.display()
                )));
            }
        };
        let stdin = child.stdin.take().expect("piped");
        let stdout = BufReader::new(child.stdout.take().expect("piped"));
        let mut helper = Helper {
            name,
            child,
            stdin,
            stdout,
            dir,
        };
        let hello = helper.call(&json!({"cmd": "hello"})).map_err(|e| {
            Error::Input(format!(
                "{e} (is {PYTHON_VAR}={} a Python with vtk 9 and numpy?)",
                python.display()
            ))
        })?;
        Ok((helper, hello))
    }

    fn path(&self, file: &str) -> PathBuf {
        self.dir.join(file)
    }

    fn write(&self, file: &str, bytes: &[u8]) -> Result<()> {
        let p = self.path(file);
        std::fs::write(&p, bytes).map_err(|e| Error::io(&p, e))
    }

    fn read(&self, file: &str) -> Result<Vec<u8>> {
        let p = self.path(file);
        std::fs::read(&p).map_err(|e| Error::io(&p, e))
    }

    /// Sends one message and reads its reply; a helper that died or answered with an error
    /// gives one line with the helper's last words.
    fn call(&mut self, msg: &Value) -> Result<Value> {
        let sent = writeln!(self.stdin, "{msg}").and_then(|_| self.stdin.flush());
        let mut line = String::new();
        let got = sent.and_then(|_| self.stdout.read_line(&mut line));
        if got.is_err() || line.trim().is_empty() {
            let status = self
                .child
                .try_wait()
                .ok()
                .flatten()
                .map(|s| format!(" ({s})"))
                .unwrap_or_default();
            return Err(Error::Internal(format!(
                "{}: the VTK helper stopped{status}{}",
                self.name,
                last_words(&self.path("stderr.log"))
            )));
        }
        let reply: Value = serde_json::from_str(line.trim()).map_err(|e| {
            Error::Internal(format!("{}: unreadable reply from the VTK helper: {e}", self.name))
        })?;
        if reply["ok"].as_bool() != Some(true) {
            return Err(Error::Internal(format!(
                "{}: VTK: {}",
                self.name,
                reply["error"].as_str().unwrap_or("unknown error")
            )));
        }
        Ok(reply)
    }
}

/// `: <last non-empty line of the helper's stderr>`, or nothing.
fn last_words(log: &Path) -> String {
    std::fs::read_to_string(log)
        .ok()
        .and_then(|t| t.lines().rev().find(|l| !l.trim().is_empty()).map(|l| format!(": {}", l.trim())))
        .unwrap_or_default()
}

impl Drop for Helper {
    fn drop(&mut self) {
        let _ = writeln!(self.stdin, "{}", json!({"cmd": "quit"}));
        let _ = self.stdin.flush();
        // Give it a moment to leave on its own, then make sure it is gone.
        for _ in 0..50 {
            if matches!(self.child.try_wait(), Ok(Some(_))) {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        if !matches!(self.child.try_wait(), Ok(Some(_))) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aligned_grid_has_two_w_plus_one_rays() {
        for w in [1, 2, 3, 63, 64, 100, 128, 512, 1000, 1024, 4096] {
            let isd = aligned_isd(w);
            assert_eq!(rays_across(w, isd), 2 * w + 1, "w = {w}");
        }
    }

    #[test]
    fn unknown_parameters_and_grids_are_refused() {
        let bad = |name: &str, k: &str, v: &str| {
            let o = RenderOptions {
                params: vec![(k.into(), v.into())],
                ..Default::default()
            };
            let m = match name {
                "pt" => Mapper::Pt,
                _ => Mapper::Raycast,
            };
            match VtkPeer::make(m, &o) {
                Err(e) => e.to_string(),
                Ok(_) => String::new(),
            }
        };
        assert!(bad("pt", "grid", "aligned").contains("unknown parameter 'grid'"));
        assert!(bad("raycast", "grid", "fine").contains("expected vtk or aligned"));
        assert!(bad("raycast", "isd", "1").contains("unknown parameter 'isd'"));
    }
}
