//! The datasets of an experiment: a mesh name (short name, file, `datasets-gen` name with an
//! optional size) or a table with options, among them a lattice over [-1, 1]³ that samples an
//! analytic field (`cells`, `field`), which the `analytic` yardstick integrates exactly.

use std::fmt;
use std::path::Path;

use algorithms::{Error, Result};
use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer};

use crate::meshes::{self, LatticeSpec, MeshSpec, Source};

/// A dataset: a string (`name[:tets]`, short name or file) or a table.
#[derive(Debug, Clone, Default)]
pub struct DatasetSpec {
    pub mesh: String,
    pub tets: Option<usize>,
    pub scalar: Option<String>,
    pub split: Option<u8>,
    pub label: Option<String>,
    /// With `mesh` = `cc5`, `cc6` or `bcc`: the lattice is built with this many CC cells per
    /// axis over [-1, 1]³ (`bcc`: the lattice of the same information, primary spacing
    /// √2·2/cells), instead of being fitted to a tet count.
    pub cells: Option<usize>,
    /// With `cells`: the analytic field the lattice samples ([`meshes::FIELDS`]; default
    /// `marschner-lobb`).
    pub field: Option<String>,
    /// With `cells`: the step of the analytic ground truth along a ray, world units (default a
    /// tenth of the CC spacing, 2/cells/10).
    pub truth_step: Option<f64>,
    /// With `cells`: `"box"` frames the camera on the lattice's box [-1, 1]³ instead of the
    /// mesh's bounding box (`"mesh"`, the default; CONVENTIONS §2), so that lattices whose
    /// meshes reach beyond the box (`bcc`) are seen exactly as the others.
    pub frame: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DatasetTable {
    mesh: String,
    #[serde(default)]
    tets: Option<usize>,
    #[serde(default)]
    scalar: Option<String>,
    #[serde(default)]
    split: Option<u8>,
    #[serde(default)]
    label: Option<String>,
    #[serde(default)]
    cells: Option<usize>,
    #[serde(default)]
    field: Option<String>,
    #[serde(default)]
    truth_step: Option<f64>,
    #[serde(default)]
    frame: Option<String>,
}

impl<'de> Deserialize<'de> for DatasetSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = DatasetSpec;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a mesh name/file string or a table { mesh = ..., tets = ... }")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> std::result::Result<DatasetSpec, E> {
                Ok(DatasetSpec {
                    mesh: s.to_string(),
                    ..Default::default()
                })
            }
            fn visit_map<A: MapAccess<'de>>(
                self,
                m: A,
            ) -> std::result::Result<DatasetSpec, A::Error> {
                let t = DatasetTable::deserialize(de::value::MapAccessDeserializer::new(m))?;
                Ok(DatasetSpec {
                    mesh: t.mesh,
                    tets: t.tets,
                    scalar: t.scalar,
                    split: t.split,
                    label: t.label,
                    cells: t.cells,
                    field: t.field,
                    truth_step: t.truth_step,
                    frame: t.frame,
                })
            }
        }
        d.deserialize_any(V)
    }
}

/// The most CC cells per axis a lattice dataset may ask for (cc6: 6·300³ = 162 M tets).
pub const MAX_CELLS: usize = 300;

/// Checks one dataset's names and values (one line naming what is wrong).
pub(super) fn check_dataset(d: &DatasetSpec, base: &Path) -> Result<()> {
    if let Some(s) = d.split {
        if s != 5 && s != 6 {
            return Err(Error::Input(format!(
                "split = {s}: expected 5 or 6 tets per hexahedron"
            )));
        }
    }
    let name = d.mesh.as_str();
    if d.cells.is_some() || d.field.is_some() || d.truth_step.is_some() || d.frame.is_some() {
        if d.cells.is_none() {
            return Err(Error::Input(format!(
                "'{name}': `field`, `truth_step` and `frame` go with `cells` (a lattice built over [-1, 1]³)"
            )));
        }
        if d.tets.is_some() || name.contains(':') {
            return Err(Error::Input(format!(
                "'{name}': give the lattice's size either as `cells` or as a tet count, not both"
            )));
        }
        d.lattice()?;
        return Ok(());
    }
    if let Source::Generated { tets, .. } = meshes::resolve(name, base)? {
        if tets.is_some() && d.tets.is_some() {
            return Err(Error::Input(format!(
                "'{name}': give the size either after ':' or as `tets`, not both"
            )));
        }
        if d.tets == Some(0) {
            return Err(Error::Input(format!("'{name}': tets must be at least 1")));
        }
    }
    Ok(())
}

impl DatasetSpec {
    /// The dataset's name in the CSV: the label, else the name as given (with `:tets`, or the
    /// lattice's cells and field).
    pub fn display_name(&self) -> String {
        if let Some(l) = &self.label {
            return l.clone();
        }
        match (self.tets, self.cells) {
            (Some(t), _) => format!("{}:{t}", self.mesh),
            (None, Some(c)) => format!(
                "{}:{c}-cells:{}",
                self.mesh,
                self.field.as_deref().unwrap_or(meshes::FIELDS[0].name)
            ),
            (None, None) => self.mesh.clone(),
        }
    }

    /// The lattice this dataset builds, when it gives `cells`.
    pub fn lattice(&self) -> Result<Option<LatticeSpec>> {
        let Some(cells) = self.cells else {
            return Ok(None);
        };
        if !(1..=MAX_CELLS).contains(&cells) {
            return Err(Error::Input(format!(
                "'{}': cells = {cells}: expected 1 to {MAX_CELLS} cells per axis",
                self.mesh
            )));
        }
        let field = meshes::field(self.field.as_deref().unwrap_or(meshes::FIELDS[0].name))?;
        let step = self.truth_step.unwrap_or(2.0 / cells as f64 / 10.0);
        if !(step.is_finite() && step > 0.0) {
            return Err(Error::Input(format!(
                "'{}': truth_step = {step}: expected a positive world length",
                self.mesh
            )));
        }
        let mut l = LatticeSpec::new(&self.mesh, cells, field, step)?;
        l.frame_box = match self.frame.as_deref() {
            None | Some("mesh") => false,
            Some("box") => true,
            Some(other) => {
                return Err(Error::Input(format!(
                    "'{}': frame = '{other}': expected mesh or box",
                    self.mesh
                )))
            }
        };
        Ok(Some(l))
    }

    /// The mesh to load ([`meshes::load_mesh`]), a relative file resolved against `base`.
    pub fn mesh_spec(&self, base: &Path, seed: u64) -> Result<MeshSpec> {
        let mut mesh = self.mesh.clone();
        if !Path::new(&mesh).exists() && base.join(&mesh).exists() {
            mesh = base.join(&mesh).display().to_string();
        }
        if let Some(t) = self.tets {
            mesh = format!("{mesh}:{t}");
        }
        Ok(MeshSpec {
            scalar: self.scalar.clone(),
            split: self.split,
            seed,
            lattice: self.lattice()?,
            ..MeshSpec::named(&mesh)
        })
    }
}
