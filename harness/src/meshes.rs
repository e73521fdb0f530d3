//! Where meshes come from: a file, a NASA short name (`blunt`, `post`, `comb`) or a
//! `datasets-gen` name with an optional size (`spx`, `fighter:200000`). The CLI and experiment
//! files turn their arguments into a plain [`MeshSpec`]; [`resolve`] says which kind of source a
//! name is (checked before any work), and [`load_mesh`] reads or generates it.

use std::path::{Path, PathBuf};

use algorithms::io::{self, LoadOptions, Split};
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
        }
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
