//! The images errors are measured against ([`Yardstick`]), one per variant and cell: the exact
//! `reference` renderer's and the analytic ground truth, cached by content hash in the cache
//! directory (shared between runs: their code changes rarely, and [`REFERENCE_VERSION`] or
//! [`ANALYTIC_VERSION`] is bumped when it does); another renderer's, kept in `DIR/.yardsticks/`
//! for this run only (renderers change often, and a stale image would be a false error).
//!
//! They are made before any variant of the dataset is measured, so that they never interleave
//! with a measured renderer. One that cannot be made leaves its cells' rows without an error and
//! with a note that says why; the run goes on (and exits 3).
//!
//! Every image is stored with a checksum beside it (`ref-KEY.b3`: blake3 of the key and the
//! pixels), and only an image that matches its checksum is used: an entry that was changed,
//! damaged, replaced by another image (all black, all NaN) or swapped with another entry is
//! rendered again. A made image with a NaN or infinite pixel is refused as a yardstick.

use std::collections::BTreeMap;

use algorithms::bcc::lattice::LatticeKind;
use algorithms::bcc::recon::{self, BccDomain, Sampling};
use algorithms::glam::DVec3;
use algorithms::mesh::Aabb;
use algorithms::optics::integrator;

use super::*;
use crate::experiment::{Over, Yardstick};
use crate::meshes::LatticeSpec;

/// Bumped when the exact reference renderer's output changes, so old cache entries are not
/// reused.
pub(super) const REFERENCE_VERSION: &str = "reference-exact-v1";
/// Bumped when the analytic ground truth's integration changes.
const ANALYTIC_VERSION: &str = "analytic-exact-v1";

/// Where the yardstick images of this run live: `.yardsticks/` for renderers' images.
pub(super) const RUN_DIR: &str = ".yardsticks";

/// The file of variant `var`'s yardstick image for (mesh, cell).
pub(super) fn ref_path(
    opts: &RunOptions,
    mesh: &blake3::Hash,
    var: &Variant,
    lattice: Option<&LatticeSpec>,
    cell: &Cell,
) -> PathBuf {
    let framed = lattice.is_some_and(|l| l.frame_box);
    let mut x = blake3::Hasher::new();
    let dir = match &var.yardstick {
        Yardstick::Exact => {
            x.update(REFERENCE_VERSION.as_bytes());
            &opts.cache_dir
        }
        Yardstick::Renderer(name) => {
            x.update(b"renderer-yardstick-v1");
            x.update(name.as_bytes());
            x.update(format!("{:?}", var.options).as_bytes());
            &opts.out.join(RUN_DIR)
        }
        Yardstick::Analytic(over) => {
            x.update(ANALYTIC_VERSION.as_bytes());
            x.update(format!("{over:?}").as_bytes());
            if let Some(l) = lattice {
                x.update(l.field.name.as_bytes());
                x.update(&l.truth_step.to_le_bytes());
            }
            &opts.cache_dir
        }
    };
    x.update(mesh.as_bytes());
    x.update(cell.projection.name().as_bytes());
    x.update(&cell.size.0.to_le_bytes());
    x.update(&cell.size.1.to_le_bytes());
    x.update(&cell.view.view.azimuth.to_le_bytes());
    x.update(&cell.view.view.elevation.to_le_bytes());
    if framed {
        // Framed on the lattice's box, not the mesh's bounding box.
        x.update(b"frame-lattice-box");
    }
    tf_bytes(&mut x, &var.tf);
    let hex = x.finalize().to_hex();
    dir.join(format!("ref-{}.exr", &hex[..32]))
}

/// What makes one yardstick's images: variants that share it share its images.
fn maker_key(var: &Variant) -> String {
    match &var.yardstick {
        Yardstick::Renderer(n) => format!("{n}|{:?}|{:?}", var.options, var.tf),
        y => format!("{y:?}|{:?}", var.tf),
    }
}

/// How many different yardsticks the experiment's variants have (images per cell, at most).
pub(super) fn kinds(exp: &Experiment) -> usize {
    let keys: std::collections::BTreeSet<String> = exp.variants.iter().map(maker_key).collect();
    keys.len()
}

/// A yardstick ready to render cells.
enum Maker {
    Renderer(Box<dyn Renderer>),
    Analytic(Over, LatticeSpec),
}

impl Maker {
    fn new(var: &Variant, mesh: &Mesh, lattice: Option<&LatticeSpec>) -> Result<Maker> {
        let (name, options) = match &var.yardstick {
            Yardstick::Exact => ("reference", RenderOptions::default()),
            Yardstick::Renderer(n) => (n.as_str(), var.options.clone()),
            Yardstick::Analytic(over) => {
                let l = lattice.ok_or_else(|| {
                    Error::Input("the dataset has no analytic field (`cells`)".into())
                })?;
                return Ok(Maker::Analytic(*over, *l));
            }
        };
        let mut r = render::make(name, &options)?;
        cell::isolated(|| r.prepare(mesh, &var.tf))?;
        Ok(Maker::Renderer(r))
    }

    fn image(&mut self, mesh: &Mesh, tf: &TransferFunction, cam: &Camera) -> Result<Image> {
        match self {
            Maker::Renderer(r) => cell::isolated(|| r.render(mesh, cam)).map(|f| f.image),
            Maker::Analytic(over, l) => analytic(mesh, l, *over, tf, cam),
        }
    }
}

/// The lattice's analytic field ray-integrated with `exact` every `truth_step`: over the mesh's
/// cells with the mesh's `L` (CONVENTIONS §1), or over the lattice's box with the box's `L` (a
/// regular volume's, as `volume-raycast` takes it).
fn analytic(
    mesh: &Mesh,
    l: &LatticeSpec,
    over: Over,
    tf: &TransferFunction,
    cam: &Camera,
) -> Result<Image> {
    let exact = integrator("exact", tf)?;
    let sampling = Sampling {
        map: tf.scalar_map(mesh.scalar_range()),
        integ: exact.as_ref(),
        step: l.truth_step,
        diag: match over {
            Over::Mesh => mesh.diagonal(),
            Over::LatticeBox => LatticeSpec::lattice_box().diagonal(),
        },
    };
    // Rays are clipped to `bbox`; `inside` cuts the domain out of it (a CC lattice's cells
    // fill their box).
    let bbox = match over {
        Over::Mesh => mesh.bbox(),
        Over::LatticeBox => LatticeSpec::lattice_box(),
    };
    let inside: Box<dyn Fn(DVec3) -> bool + Sync> = match (over, l.kind) {
        (Over::LatticeBox, _) | (_, LatticeKind::Cc5 | LatticeKind::Cc6) => Box::new(|_| true),
        (Over::Mesh, LatticeKind::Bcc) => {
            let lat = mesh
                .field_data
                .get(datasets_gen::LATTICE_KEY)
                .and_then(|v| algorithms::bcc::lattice::Lattice::from_field_data(v))
                .ok_or_else(|| Error::Internal("a lattice dataset without its lattice".into()))?;
            let dom = BccDomain {
                n: lat.n,
                origin: lat.origin,
                h: lat.spacing,
            };
            Box::new(move |p| dom.contains(p))
        }
    };
    recon::ground_truth(&l.field.f, &*inside, &bbox, cam, sampling)
}

/// The yardstick images of one dataset: for every variant in `need` (index into the
/// experiment's variants, with the cells of it still to measure), each cell's image rendered or
/// found. A yardstick that fails leaves its message in `failed` (by file). False when
/// interrupted.
#[allow(clippy::too_many_arguments)]
pub(super) fn references(
    exp: &Experiment,
    opts: &RunOptions,
    mesh: &Mesh,
    hash: &blake3::Hash,
    lattice: Option<&LatticeSpec>,
    frame: &Aabb,
    cells: &[Cell],
    need: &[(usize, Vec<usize>)],
    bar: &ProgressBar,
    name: &str,
    out: &mut Outcome,
    failed: &mut BTreeMap<PathBuf, String>,
) -> Result<bool> {
    // Group the variants by what makes their yardstick; each group's cells once.
    let mut groups: Vec<(String, usize, Vec<usize>)> = Vec::new();
    for (v, cs) in need {
        let key = maker_key(&exp.variants[*v]);
        let g = match groups.iter().position(|g| g.0 == key) {
            Some(i) => i,
            None => {
                groups.push((key, *v, Vec::new()));
                groups.len() - 1
            }
        };
        for &c in cs {
            if !groups[g].2.contains(&c) {
                groups[g].2.push(c);
            }
        }
    }
    for (_, v, mut cs) in groups {
        cs.sort_unstable();
        let var = &exp.variants[v];
        let mut maker: Option<std::result::Result<Maker, String>> = None;
        for c in cs {
            let cell = &cells[c];
            if measure::interrupted() {
                out.interrupted = true;
                return Ok(false);
            }
            let (w, h) = cell.size;
            bar.set_message(format!(
                "{name}: {} {w}x{h} {}",
                var.yardstick.label(),
                cell.view.id
            ));
            let p = ref_path(opts, hash, var, lattice, cell);
            match read_entry(&p) {
                Ok(_) => {
                    out.reference_hits += 1;
                    bar.inc(1);
                    continue;
                }
                Err(e) if std::fs::symlink_metadata(&p).is_ok() => {
                    progress::note(bar, &format!("{name}: {e}; rendering it again"));
                }
                Err(_) => {}
            }
            let m = maker.get_or_insert_with(|| {
                Maker::new(var, mesh, lattice)
                    .map_err(|e| format!("{} could not be prepared: {e}", var.yardstick.label()))
            });
            let cam = Camera::new(frame, cell.view.view, cell.projection, w, h);
            let made = match m {
                Ok(m) => m
                    .image(mesh, &var.tf, &cam)
                    .map_err(|e| format!("{}: {e}", var.yardstick.label())),
                Err(e) => Err(e.clone()),
            };
            let made = made.and_then(|img| match img.non_finite_pixels() {
                0 => Ok(img),
                n => Err(format!(
                    "{}: {n} pixels of its image are NaN or infinite; no error is measured against it",
                    var.yardstick.label()
                )),
            });
            match made {
                Ok(img) => {
                    if let Some(d) = p.parent() {
                        std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
                    }
                    write_entry(&p, &img)?;
                    out.reference_renders += 1;
                }
                Err(why) => {
                    progress::note(bar, &format!("{name}: {why}"));
                    failed.insert(p, why);
                }
            }
            bar.inc(1);
        }
    }
    Ok(true)
}

/// The checksum file beside a yardstick image: `ref-KEY.b3`.
fn sum_path(p: &Path) -> PathBuf {
    p.with_extension("b3")
}

/// blake3 of an entry's key (its file name) and its image's size and pixels.
fn checksum(p: &Path, img: &Image) -> String {
    let mut h = blake3::Hasher::new();
    h.update(b"tetbench-yardstick-v1");
    h.update(p.file_name().unwrap_or_default().as_encoded_bytes());
    h.update(&img.width.to_le_bytes());
    h.update(&img.height.to_le_bytes());
    for px in &img.pixels {
        for c in px {
            h.update(&c.to_le_bytes());
        }
    }
    h.finalize().to_hex().to_string()
}

/// Stores a yardstick image and then its checksum (each atomically: an entry whose checksum is
/// missing is not used).
pub(super) fn write_entry(p: &Path, img: &Image) -> Result<()> {
    img.write(p)?;
    let sum = checksum(p, img);
    algorithms::io::atomic_write(&sum_path(p), |w| {
        std::io::Write::write_all(w, format!("{sum}\n").as_bytes())
    })
}

/// A yardstick image that matches its checksum, or one line saying why it is not used.
pub(super) fn read_entry(p: &Path) -> Result<Image> {
    let img = Image::read(p)?;
    let sp = sum_path(p);
    let stored = algorithms::io::read_input_string(&sp, 1024).map_err(|e| {
        Error::Input(format!(
            "{}: no valid checksum beside it ({e})",
            p.display()
        ))
    })?;
    if stored.trim() != checksum(p, &img) {
        return Err(Error::Input(format!(
            "{}: does not match its checksum (changed, damaged or swapped since it was made)",
            p.display()
        )));
    }
    Ok(img)
}

fn tf_bytes(h: &mut blake3::Hasher, tf: &TransferFunction) {
    h.update(tf.name.as_bytes());
    match tf.range {
        Some([a, b]) => {
            h.update(&[1]);
            h.update(&a.to_le_bytes());
            h.update(&b.to_le_bytes());
        }
        None => {
            h.update(&[0]);
        }
    }
    for p in &tf.points {
        h.update(&p.s.to_le_bytes());
        for c in p.rgb {
            h.update(&c.to_le_bytes());
        }
        h.update(&p.tau.to_le_bytes());
    }
}
