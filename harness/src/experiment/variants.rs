//! The renderers of an experiment and their expansion into variants (renderer × sort ×
//! integrator, with parameters, transfer function and the yardstick its error is measured
//! against).

use std::collections::BTreeMap;
use std::path::Path;

use algorithms::render::{self, RenderOptions};
use algorithms::{Error, Result, TransferFunction};
use serde::Deserialize;

use super::tf::TfSpec;

/// A renderer with the sorts and integrators to try (each absent: the renderer's default;
/// `["*"]`: every one the registry lists for it, but the lattice-only sorts).
#[derive(Deserialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct RendererSpec {
    pub name: String,
    #[serde(default)]
    pub sorts: Option<Vec<String>>,
    #[serde(default)]
    pub integrators: Option<Vec<String>>,
    /// Renderer parameters (`RenderOptions::params`), e.g. `params = { mode = "iso", iso =
    /// "0.5" }`; they are added to the variant label as `[k=v,...]`.
    #[serde(default)]
    pub params: BTreeMap<String, String>,
    /// Run this renderer only on meshes with at most this many tets (the others get no row,
    /// and the run says so): e.g. a GPU renderer on a software rasteriser.
    #[serde(default)]
    pub max_tets: Option<usize>,
    /// A renderer that may not be able to run on this machine (VTK's peers without
    /// `TETBENCH_VTK_PYTHON`, a GPU renderer without an adapter): when it cannot be made, its
    /// rows are failed rows whose note says why (NaN times), and the rest of the run goes on,
    /// instead of the whole experiment being refused.
    #[serde(default)]
    pub optional: bool,
    /// This renderer's transfer function instead of the experiment's (added to the variant
    /// label as `[tf=NAME]`).
    #[serde(default)]
    pub tf: Option<TfSpec>,
    /// Run this renderer only on these datasets (their names in the `dataset` column).
    #[serde(default)]
    pub datasets: Option<Vec<String>>,
    /// What its error is measured against (see [`Yardstick::parse`]): `"reference"` (the
    /// default), another renderer's name, `"analytic"` or `"analytic-box"`.
    #[serde(default)]
    pub reference: Option<String>,
}

/// Where the analytic ground truth integrates the field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Over {
    /// The mesh's own cells (a `bcc` mesh: the octahedra of its primary edges).
    Mesh,
    /// The lattice's primary box, [-1, 1]³ (what a regular-volume ray caster covers).
    LatticeBox,
}

/// The image a variant's error is measured against, per cell.
#[derive(Clone, Debug, PartialEq)]
pub enum Yardstick {
    /// The exact `reference` renderer (`exact` integrator, f64), cached by content hash.
    Exact,
    /// This renderer's image, made with the variant's own sort, integrator and parameters: e.g.
    /// the full-size image of the renderer a `jbu:` wrapper upsamples.
    Renderer(String),
    /// The dataset's analytic field ray-integrated with `exact` (a lattice dataset: `cells`).
    Analytic(Over),
}

impl Yardstick {
    /// `reference`, `analytic`, `analytic-box` or a renderer's name.
    pub fn parse(s: &str) -> Result<Yardstick> {
        Ok(match s {
            "reference" => Yardstick::Exact,
            "analytic" => Yardstick::Analytic(Over::Mesh),
            "analytic-box" => Yardstick::Analytic(Over::LatticeBox),
            name => {
                render::info(name).map_err(|e| {
                    Error::Input(format!(
                        "reference: '{name}': expected reference, analytic, analytic-box or a renderer ({e})"
                    ))
                })?;
                Yardstick::Renderer(name.to_string())
            }
        })
    }

    /// Its name in the `reference` column.
    pub fn label(&self) -> String {
        match self {
            Yardstick::Exact => "reference".into(),
            Yardstick::Renderer(n) => n.clone(),
            Yardstick::Analytic(Over::Mesh) => "analytic".into(),
            Yardstick::Analytic(Over::LatticeBox) => "analytic-box".into(),
        }
    }
}

/// One renderer variant: how to make it and its label (`renderer/sort/integrator`).
#[derive(Debug, Clone)]
pub struct Variant {
    pub renderer: String,
    /// See [`RendererSpec::max_tets`].
    pub max_tets: Option<usize>,
    /// Why an `optional` renderer cannot run here (see [`RendererSpec::optional`]).
    pub unavailable: Option<String>,
    pub options: RenderOptions,
    pub label: String,
    pub sort: String,
    pub integrator: String,
    /// The transfer function it renders with, and its name in the `tf` column.
    pub tf_name: String,
    pub tf: TransferFunction,
    /// See [`RendererSpec::datasets`].
    pub datasets: Option<Vec<String>>,
    pub yardstick: Yardstick,
}

impl Variant {
    /// Everything but its label that makes its rows what they are: two entries that give one
    /// label are one variant only when this agrees too.
    pub fn signature(&self) -> String {
        format!(
            "{:?}|{:?}|{:?}|{:?}|{:?}|{:?}",
            self.yardstick, self.max_tets, self.datasets, self.tf, self.options, self.unavailable
        )
    }

    /// Whether it runs on the dataset named `dataset` with `tets` tets.
    pub fn runs_on(&self, dataset: &str, tets: usize) -> bool {
        self.max_tets.is_none_or(|m| tets <= m)
            && self
                .datasets
                .as_ref()
                .is_none_or(|d| d.iter().any(|x| x == dataset))
    }
}

/// Expands one renderer entry into its variants, making each once to check the names. `tf` is
/// the experiment's transfer function (name and function); a file in the entry's own `tf` is
/// resolved against `base`.
pub fn expand_renderer(
    r: &RendererSpec,
    tf: &(String, TransferFunction),
    base: &Path,
) -> Result<Vec<Variant>> {
    let info = render::info(&r.name)?;
    let sorts: Vec<Option<String>> = match &r.sorts {
        None => vec![None],
        Some(v) if v.iter().any(|s| s == "*") => info
            .sorts
            .iter()
            .filter(|s| !algorithms::sort::info(s).is_ok_and(|i| i.lattice_only))
            .map(|s| Some(s.to_string()))
            .collect(),
        Some(v) if v.is_empty() => vec![None],
        Some(v) => v.iter().map(|s| Some(s.clone())).collect(),
    };
    let integrators: Vec<Option<String>> = match &r.integrators {
        None => vec![None],
        Some(v) if v.iter().any(|s| s == "*") => info
            .integrators
            .iter()
            .map(|s| Some(s.to_string()))
            .collect(),
        Some(v) if v.is_empty() => vec![None],
        Some(v) => v.iter().map(|s| Some(s.clone())).collect(),
    };
    let sorts = if sorts.is_empty() { vec![None] } else { sorts };
    let (tf_name, tf) = match &r.tf {
        None => tf.clone(),
        Some(spec) => {
            let t = spec.resolve(base).map_err(|e| prefixed("tf", e))?;
            (t.name.clone(), t)
        }
    };
    let yardstick = match &r.reference {
        None => Yardstick::Exact,
        Some(s) => Yardstick::parse(s)?,
    };
    // Parameters and an own transfer function, as `[k=v,...,tf=NAME]` after the label.
    let suffix = {
        let mut kv: Vec<String> = r.params.iter().map(|(k, v)| format!("{k}={v}")).collect();
        if r.tf.is_some() {
            kv.push(format!("tf={tf_name}"));
        }
        if kv.is_empty() {
            String::new()
        } else {
            format!("[{}]", kv.join(","))
        }
    };
    let mut out = Vec::new();
    for s in &sorts {
        for i in &integrators {
            let options = RenderOptions {
                sort: s.clone(),
                integrator: i.clone(),
                params: r
                    .params
                    .iter()
                    .map(|(k, v)| (k.clone(), v.clone()))
                    .collect(),
                log_dir: None,
            };
            let variant = |renderer: String, sort: String, integrator: String, why| Variant {
                label: variant_label(&renderer, &sort, &integrator) + &suffix,
                renderer,
                max_tets: r.max_tets,
                unavailable: why,
                options: options.clone(),
                sort,
                integrator,
                tf_name: tf_name.clone(),
                tf: tf.clone(),
                datasets: r.datasets.clone(),
                yardstick: yardstick.clone(),
            };
            let made = match render::make(&r.name, &options) {
                Ok(m) => m,
                Err(e) if r.optional => {
                    // Named as it would be: the default sort and integrator where none is given.
                    let sort = s.clone().unwrap_or_else(|| info.default_sort.to_string());
                    let integrator = i
                        .clone()
                        .unwrap_or_else(|| info.default_integrator.to_string());
                    out.push(variant(
                        r.name.clone(),
                        sort,
                        integrator,
                        Some(e.to_string()),
                    ));
                    continue;
                }
                Err(e) => return Err(e),
            };
            if let Yardstick::Renderer(y) = &yardstick {
                // The yardstick takes the variant's own options.
                render::make(y, &options).map_err(|e| prefixed("reference", e))?;
            }
            let d = made.describe();
            out.push(variant(d.name, d.sort, d.integrator, None));
        }
    }
    Ok(out)
}

/// An input error of the entry's key `key`, as `key: message`.
fn prefixed(key: &str, e: Error) -> Error {
    match e {
        Error::Input(m) | Error::Io(m) => Error::Input(format!("{key}: {m}")),
        other => other,
    }
}

/// `renderer/sort/integrator`, leaving out empty parts.
pub fn variant_label(renderer: &str, sort: &str, integrator: &str) -> String {
    let mut l = renderer.to_string();
    for p in [sort, integrator] {
        if !p.is_empty() {
            l.push('/');
            l.push_str(p);
        }
    }
    l
}
