//! Where meshes come from: a file, a NASA short name (`blunt`, `post`, `comb`) or a
//! `datasets-gen` name with an optional size (`spx`, `fighter:200000`). The CLI and experiment
//! files turn their arguments into a plain [`MeshSpec`]; [`resolve`] says which kind of source a
//! name is (checked before any work), and [`load_mesh`] reads or generates it. Experiments may
//! also ask for a lattice over [-1, 1]³ sampling a known analytic field ([`LatticeSpec`]), whose
//! exact image is then known too.

use std::path::{Path, PathBuf};

use algorithms::bcc::lattice::LatticeKind;
use algorithms::glam::DVec3;
use algorithms::io::{self, LoadOptions, Split};
use algorithms::mesh::Aabb;
use algorithms::{Error, Mesh, Result};

/// The seed of generated meshes when none is given (the same as `datasets-gen --seed`).
pub const DEFAULT_SEED: u64 = datasets_gen::DEFAULT_SEED;

/// How to find and read one mesh.
#[derive(Debug, Clone)]
pub struct MeshSpec {
    /// File, short name or `datasets-gen` name[:tets].
    pub mesh: String,
    /// Scalar field to make active (PLOT3D: density, energy, velocity, momentum-x|y|z).
    pub scalar: Option<String>,
    /// PLOT3D q file (default: the xyz name with `xyz` replaced by `q`).
    pub q_file: Option<PathBuf>,
    /// Split hexahedra (and wedges, pyramids) into 5 or 6 tets.
    pub split: Option<u8>,
    /// A `.off` file with 1-based indices.
    pub one_based: bool,
    /// Seed of `datasets-gen` meshes.
    pub seed: u64,
    /// Built as this lattice instead (`mesh` is then its kind's name).
    pub lattice: Option<LatticeSpec>,
}

impl MeshSpec {
    /// A mesh by name with every option at its default.
    pub fn named(mesh: &str) -> MeshSpec {
        MeshSpec {
            mesh: mesh.to_string(),
            scalar: None,
            q_file: None,
            split: None,
            one_based: false,
            seed: DEFAULT_SEED,
            lattice: None,
        }
    }
}

/// An analytic field over [-1, 1]³ with values in [0, 1]: what a lattice dataset samples, and
/// what the `analytic` yardstick integrates along each ray.
#[derive(Debug)]
pub struct AnalyticField {
    pub name: &'static str,
    pub description: &'static str,
    pub f: fn(DVec3) -> f64,
}

fn shell(p: DVec3) -> f64 {
    datasets_gen::fields::spherical_shell(p, DVec3::ZERO, 0.6, 0.15)
}

/// The analytic fields lattice datasets can sample (the first is the default).
pub static FIELDS: [AnalyticField; 2] = [
    AnalyticField {
        name: "marschner-lobb",
        description: "Marschner-Lobb, f_M = 6, alpha = 0.25",
        f: datasets_gen::fields::marschner_lobb,
    },
    AnalyticField {
        name: "shell",
        description: "spherical shell, radius 0.6, width 0.15",
        f: shell,
    },
];

/// The analytic field called `name`; one line listing them otherwise.
pub fn field(name: &str) -> Result<&'static AnalyticField> {
    FIELDS.iter().find(|f| f.name == name).ok_or_else(|| {
        let names: Vec<&str> = FIELDS.iter().map(|f| f.name).collect();
        Error::Input(format!(
            "field '{name}': no such analytic field (fields: {}){}",
            names.join(", "),
            algorithms::plugin::did_you_mean(name, &names)
        ))
    })
}

/// Primary points per axis of the `bcc` lattice with the information of `cells` CC cells per
/// axis: `round(cells/√2) + 1`.
pub fn bcc_points(cells: usize) -> usize {
    (cells as f64 / std::f64::consts::SQRT_2).round().max(1.0) as usize + 1
}

/// A lattice over [-1, 1]³ sampling an analytic field: `cc5` or `cc6` with `cells` cells per
/// axis (spacing h = 2/cells), or `bcc` with the same information (primary spacing nearest
/// √2·h: `round(cells/√2)` cells per axis, BCC paper §4). Its ground truth is the field itself,
/// integrated along each ray every `truth_step` (world units).
#[derive(Clone, Copy, Debug)]
pub struct LatticeSpec {
    pub kind: LatticeKind,
    pub cells: usize,
    pub field: &'static AnalyticField,
    pub truth_step: f64,
    /// Frame the camera on the lattice's box [-1, 1]³ instead of the mesh's bounding box
    /// (a `bcc` mesh reaches half a cell beyond the box), so that lattices of different extent
    /// over the one box are seen alike.
    pub frame_box: bool,
}

impl LatticeSpec {
    /// `kind` is `cc5`, `cc6` or `bcc`.
    pub fn new(
        kind: &str,
        cells: usize,
        field: &'static AnalyticField,
        truth_step: f64,
    ) -> Result<LatticeSpec> {
        let kind = match kind {
            "cc5" => LatticeKind::Cc5,
            "cc6" => LatticeKind::Cc6,
            "bcc" => LatticeKind::Bcc,
            other => {
                return Err(Error::Input(format!(
                    "'{other}': `cells` builds the lattices cc5, cc6 and bcc only"
                )))
            }
        };
        Ok(LatticeSpec {
            kind,
            cells,
            field,
            truth_step,
            frame_box: false,
        })
    }

    /// Primary points per axis of the `bcc` lattice: `round(cells/√2) + 1`.
    pub fn bcc_points(&self) -> usize {
        bcc_points(self.cells)
    }

    /// The box the camera frames for `mesh` built from this lattice.
    pub fn frame(&self, mesh: &Mesh) -> Aabb {
        if self.frame_box {
            Self::lattice_box()
        } else {
            mesh.bbox()
        }
    }

    /// The lattice's (primary) box, [-1, 1]³: where a regular-volume ray caster samples it.
    pub fn lattice_box() -> Aabb {
        Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::ONE,
        }
    }

    /// Builds the mesh: the lattice's tets, the field sampled at its vertices (field `f`) and
    /// the lattice description that lattice-aware sorts and renderers read.
    pub fn build(&self) -> Result<Mesh> {
        use datasets_gen::grid::{bcc_lattice, cc_lattice, Split as Cells};
        let o = DVec3::splat(-1.0);
        let (name, positions, tets, lattice) = match self.kind {
            LatticeKind::Cc5 | LatticeKind::Cc6 => {
                let (name, split) = if self.kind == LatticeKind::Cc5 {
                    ("cc5", Cells::Five)
                } else {
                    ("cc6", Cells::Six)
                };
                let h = DVec3::splat(2.0 / self.cells as f64);
                let (b, l) = cc_lattice([self.cells; 3], split, o, h);
                (name, b.positions, b.tets, l)
            }
            LatticeKind::Bcc => {
                let n = self.bcc_points();
                let h = DVec3::splat(2.0 / (n - 1) as f64);
                let (p, t, l) = bcc_lattice([n; 3], o, h);
                ("bcc", p, t, l)
            }
        };
        let s = datasets_gen::fields::sample(&positions, self.field.f);
        let mut m = Mesh::with_scalars(name, positions, tets, "f", s)?;
        m.field_data
            .insert(datasets_gen::LATTICE_KEY.into(), lattice.to_field_data());
        Ok(m)
    }
}

/// What a mesh name stands for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// A file on disk.
    File(PathBuf),
    /// A NASA grid by short name (found, or not, in the data directories when loaded).
    Nasa(&'static str),
    /// A `datasets-gen` mesh with an optional tet count.
    Generated {
        name: &'static str,
        tets: Option<usize>,
    },
}

/// Says what `name` is: a file (as given or relative to `base`), a short name, or a generator
/// name with an optional `:tets`. An unknown name is one line with the closest known names.
pub fn resolve(name: &str, base: &Path) -> Result<Source> {
    if Path::new(name).exists() {
        return Ok(Source::File(PathBuf::from(name)));
    }
    if base.join(name).exists() {
        return Ok(Source::File(base.join(name)));
    }
    if let Some((n, _, _)) = io::SHORT_NAMES.iter().find(|(n, _, _)| *n == name) {
        return Ok(Source::Nasa(n));
    }
    let (gen, tets) = match name.split_once(':') {
        Some((g, n)) => {
            let t = n
                .trim()
                .parse::<usize>()
                .ok()
                .filter(|&t| t > 0)
                .ok_or_else(|| {
                    Error::Input(format!(
                        "{name}: the size after ':' must be a tet count (at least 1)"
                    ))
                })?;
            (g, Some(t))
        }
        None => (name, None),
    };
    match datasets_gen::find(gen) {
        Some(g) => Ok(Source::Generated { name: g.name, tets }),
        None => {
            let known: Vec<&str> = io::SHORT_NAMES
                .iter()
                .map(|(n, _, _)| *n)
                .chain(datasets_gen::generators().iter().map(|g| g.name))
                .collect();
            Err(Error::Input(format!(
                "{name}: no such file, and not a dataset name{} (see `tetbench list`)",
                algorithms::plugin::did_you_mean(gen, &known)
            )))
        }
    }
}

/// Loads (or generates) the mesh.
pub fn load_mesh(spec: &MeshSpec) -> Result<Mesh> {
    let split = match spec.split {
        None => None,
        Some(5) => Some(Split::Five),
        Some(6) => Some(Split::Six),
        Some(n) => {
            return Err(Error::Input(format!(
                "split {n}: expected 5 or 6 tets per hexahedron"
            )))
        }
    };
    let opts = LoadOptions {
        split,
        scalar: spec.scalar.clone(),
        q_file: spec.q_file.clone(),
        one_based: spec.one_based,
    };
    if let Some(l) = &spec.lattice {
        return l.build();
    }
    match resolve(&spec.mesh, Path::new("."))? {
        Source::File(p) => io::load_path(&p, &opts),
        Source::Nasa(n) => io::load(n, &opts),
        Source::Generated { name, tets } => {
            let mut mesh = datasets_gen::generate(name, tets, spec.seed)?;
            if let Some(s) = &spec.scalar {
                mesh.select_field(s, 0)?;
            }
            Ok(mesh)
        }
    }
}

/// Parses an image size `WxH` (1..=16384 each way).
pub fn parse_size(s: &str) -> Result<(u32, u32)> {
    let bad = || {
        Error::Input(format!(
            "size '{s}': expected WxH, e.g. 512x512 (1..=16384)"
        ))
    };
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(bad());
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_and_names() {
        assert_eq!(parse_size("64x32").unwrap(), (64, 32));
        assert!(parse_size("0x3").is_err() && parse_size("big").is_err());
        let here = Path::new(".");
        assert_eq!(resolve("post", here).unwrap(), Source::Nasa("post"));
        assert_eq!(
            resolve("spx:100", here).unwrap(),
            Source::Generated {
                name: "spx",
                tets: Some(100)
            }
        );
        assert!(resolve("spx:0", here).is_err());
        let e = resolve("fightr", here).unwrap_err().to_string();
        assert!(e.contains("did you mean 'fighter'"), "{e}");
    }
}
