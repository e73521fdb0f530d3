//! Experiment files (`tetbench bench CONFIG.toml`): the TOML schema, its validation with errors
//! that name the key, and the expansion into datasets × variants × sizes × views. Datasets,
//! renderers (variants and their yardsticks), transfer functions and views each have their own
//! file beside this one.
//!
//! The keys are documented in `docs/experiments.md`; `harness/experiments/example.toml` is a
//! real file that uses all of them.

use std::fmt;
use std::path::{Path, PathBuf};

use algorithms::camera::{Projection, View};
use algorithms::glam::DVec3;
use algorithms::{Error, Result, TransferFunction};
use serde::de::{self, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer};

use crate::meshes;

mod datasets;
mod tf;
mod variants;
mod views;
pub use datasets::DatasetSpec;
pub use tf::{TfSpec, TfTable};
pub use variants::{expand_renderer, variant_label, Over, RendererSpec, Variant, Yardstick};
use views::expand_views;

/// The experiment file as written.
#[derive(Deserialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Free-form name, copied into `DIR/experiment.txt`.
    #[serde(default)]
    pub name: Option<String>,
    /// Meshes: `"spx:20000"`, `"post"`, `"mesh.vtu"`, or tables with options.
    pub datasets: Vec<DatasetSpec>,
    /// Renderers, each × its sorts × its integrators.
    pub renderers: Vec<RendererSpec>,
    /// Image sizes `"WxH"` (default `["512x512"]`).
    #[serde(default)]
    pub sizes: Option<Vec<String>>,
    /// Views (default: the single view `0,0`).
    #[serde(default)]
    pub views: ViewsSpec,
    /// `"ortho"`, `"persp"` or a list of them (default `"ortho"`).
    #[serde(default)]
    pub projection: Option<OneOrMany>,
    /// Transfer function: a preset name or a JSON file (relative to the experiment file), or a
    /// table (see [`TfSpec`]).
    #[serde(default)]
    pub tf: Option<TfSpec>,
    /// Measured frames per view (median reported; default 3).
    #[serde(default)]
    pub repeats: Option<usize>,
    /// Frames rendered and thrown away before the measured ones, per view (default 1).
    #[serde(default)]
    pub warmup: Option<usize>,
    /// Measure error against the cached `reference` images (default true).
    #[serde(default)]
    pub error: Option<bool>,
    /// Measure the variants of each (dataset, projection, size, view) interleaved: all
    /// prepared at once, then warm-up and measured rounds that render each variant once in
    /// turn (A B C A B C …), instead of all frames of one variant before the next (default
    /// false).
    #[serde(default)]
    pub interleave: Option<bool>,
    /// Save every measured image as EXR and PNG under `DIR/images/` (default false).
    #[serde(default)]
    pub save_images: Option<bool>,
    /// Where reference images are cached (default `DIR/.cache`; relative to DIR).
    #[serde(default)]
    pub cache_dir: Option<PathBuf>,
    /// Seed for datasets-gen meshes (default 1).
    #[serde(default)]
    pub seed: Option<u64>,
    /// Pairs of variants compared image against image (e.g. centroid vs MPVONC), written to
    /// `DIR/pairs.csv`.
    #[serde(default)]
    pub pairs: Vec<PairSpec>,
    /// Peers this experiment declares (`[[peer]]` tables, docs/peers.md). They start programs,
    /// so the command line registers them only with `--allow-peers`, before the experiment is
    /// validated.
    #[serde(default)]
    pub peer: Vec<algorithms::render::peer::decl::PeerDecl>,
}

/// A string or a list of strings.
#[derive(Debug, Clone)]
pub struct OneOrMany(pub Vec<String>);

impl<'de> Deserialize<'de> for OneOrMany {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = OneOrMany;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a string or a list of strings")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> std::result::Result<OneOrMany, E> {
                Ok(OneOrMany(vec![s.to_string()]))
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                mut s: A,
            ) -> std::result::Result<OneOrMany, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = s.next_element::<String>()? {
                    v.push(x);
                }
                Ok(OneOrMany(v))
            }
        }
        d.deserialize_any(V)
    }
}

/// Views: named `AZ,EL` strings, N Fibonacci views, and a rotation path.
#[derive(Deserialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct ViewsSpec {
    #[serde(default)]
    pub named: Vec<String>,
    #[serde(default)]
    pub fibonacci: usize,
    #[serde(default)]
    pub rotate: Option<RotateSpec>,
}

/// A model turning about an axis, seen by a fixed camera: `frames` views evenly spaced over
/// 360°, starting at the view `start`.
#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RotateSpec {
    pub frames: usize,
    #[serde(default = "default_axis")]
    pub axis: String,
    #[serde(default)]
    pub start: Option<String>,
}

fn default_axis() -> String {
    "y".to_string()
}

/// Two variants compared image against image (labels as in the `variant` column).
#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct PairSpec {
    pub test: String,
    pub reference: String,
}

/// A view with its id in the CSV (`named:0`, `fib:3`, `rot:5`).
#[derive(Debug, Clone)]
pub struct ViewItem {
    pub id: String,
    pub view: View,
}

/// A validated, expanded experiment.
#[derive(Debug, Clone)]
pub struct Experiment {
    pub name: String,
    pub datasets: Vec<DatasetSpec>,
    pub variants: Vec<Variant>,
    pub sizes: Vec<(u32, u32)>,
    pub views: Vec<ViewItem>,
    pub projections: Vec<Projection>,
    /// The experiment's transfer function (a variant may have its own: [`Variant::tf`]).
    pub tf_name: String,
    pub tf: TransferFunction,
    pub repeats: usize,
    pub warmup: usize,
    pub error: bool,
    /// See [`Config::interleave`].
    pub interleave: bool,
    pub save_images: bool,
    pub cache_dir: Option<PathBuf>,
    pub seed: u64,
    pub pairs: Vec<PairSpec>,
    /// Directory relative dataset and TF paths are resolved against.
    pub base_dir: PathBuf,
}

/// Reads and validates an experiment file. Every error is one line naming the file and key.
pub fn load(path: &Path) -> Result<Experiment> {
    let text = algorithms::io::read_input_string(path, algorithms::io::files::MAX_SETTINGS_BYTES)?;
    let cfg = parse(&text, &path.display().to_string())?;
    let base = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    validate(cfg, &base).map_err(|e| match e {
        Error::Input(m) => Error::Input(format!("{}: {m}", path.display())),
        other => other,
    })
}

/// Parses TOML text into a [`Config`]; `source` names it in errors.
pub fn parse(text: &str, source: &str) -> Result<Config> {
    let de = toml::Deserializer::parse(text).map_err(|e| toml_error(source, text, &e, None))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        toml_error(source, text, e.inner(), Some(path))
    })
}

fn toml_error(source: &str, text: &str, e: &toml::de::Error, key: Option<String>) -> Error {
    let line = e
        .span()
        .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
    let msg = e.message().replace('\n', " ");
    let mut out = source.to_string();
    if let Some(l) = line {
        out.push_str(&format!(":{l}"));
    }
    match key {
        Some(k) if k != "." && !k.is_empty() => out.push_str(&format!(": key `{k}`: {msg}")),
        _ => out.push_str(&format!(": {msg}")),
    }
    Error::Input(out)
}

fn key_err(key: impl fmt::Display, e: Error) -> Error {
    match e {
        Error::Input(m) | Error::Io(m) => Error::Input(format!("key `{key}`: {m}")),
        other => other,
    }
}

/// Checks every name and value of a parsed config and expands it.
/// Bounds on the experiment file's counts, so that a typo cannot ask for a billion frames.
pub const MAX_VIEWS: usize = 10_000;
pub const MAX_FRAMES: usize = 10_000;
pub const MAX_LIST: usize = 1_000;

/// Refuses `n` above `max`, naming the key and the bound.
pub(crate) fn bound(key: &str, n: usize, max: usize) -> Result<()> {
    if n > max {
        return Err(Error::Input(format!(
            "key `{key}`: {n} is more than the bound {max}"
        )));
    }
    Ok(())
}

pub fn validate(cfg: Config, base: &Path) -> Result<Experiment> {
    bound("datasets", cfg.datasets.len(), MAX_LIST)?;
    bound("renderers", cfg.renderers.len(), MAX_LIST)?;
    bound("sizes", cfg.sizes.as_ref().map_or(0, Vec::len), MAX_LIST)?;
    bound("pairs", cfg.pairs.len(), MAX_LIST)?;
    bound("repeats", cfg.repeats.unwrap_or(0), MAX_FRAMES)?;
    bound("warmup", cfg.warmup.unwrap_or(0), MAX_FRAMES)?;
    if cfg.datasets.is_empty() {
        return Err(Error::Input(
            "key `datasets`: list at least one dataset".into(),
        ));
    }
    for (i, d) in cfg.datasets.iter().enumerate() {
        datasets::check_dataset(d, base).map_err(|e| key_err(format!("datasets[{i}]"), e))?;
    }
    let names: Vec<String> = cfg.datasets.iter().map(DatasetSpec::display_name).collect();
    distinct("dataset", &names, |i| format!("datasets[{i}]"))?;
    let tf = cfg
        .tf
        .clone()
        .unwrap_or_else(|| TfSpec::Named("default".into()))
        .resolve(base)
        .map_err(|e| key_err("tf", e))?;
    // A named TF keeps the name it was given (a file's path, as before).
    let tf_name = match &cfg.tf {
        Some(TfSpec::Named(n)) => n.clone(),
        _ => tf.name.clone(),
    };
    let default_tf = (tf_name.clone(), tf.clone());
    if cfg.renderers.is_empty() {
        return Err(Error::Input(
            "key `renderers`: list at least one renderer".into(),
        ));
    }
    let mut variants = Vec::new();
    // The renderer entry each variant came from, to name both of two that clash.
    let mut from: Vec<usize> = Vec::new();
    for (i, r) in cfg.renderers.iter().enumerate() {
        let v = expand_renderer(r, &default_tf, base).map_err(|e| match &e {
            Error::Input(m) if m.starts_with("unknown renderer") => {
                key_err(format!("renderers[{i}].name"), e)
            }
            _ => key_err(format!("renderers[{i}]"), e),
        })?;
        check_renderer_datasets(r, &cfg.datasets)
            .map_err(|e| key_err(format!("renderers[{i}]"), e))?;
        for x in v {
            match variants.iter().position(|y: &Variant| y.label == x.label) {
                // The same variant listed again: measured once.
                Some(j) if variants[j].signature() == x.signature() => {}
                Some(j) => {
                    return Err(Error::Input(format!(
                        "key `renderers[{i}]`: gives the variant '{}' as `renderers[{}]` does, but with another reference, max_tets, datasets or tf; give one of them other parameters so that their rows can be told apart",
                        x.label, from[j]
                    )))
                }
                None => {
                    variants.push(x);
                    from.push(i);
                }
            }
        }
    }
    let labels: Vec<String> = variants.iter().map(|v| v.label.clone()).collect();
    distinct("variant", &labels, |i| format!("renderers[{}]", from[i]))?;
    let sizes = match &cfg.sizes {
        None => vec![(512, 512)],
        Some(list) => {
            if list.is_empty() {
                return Err(Error::Input("key `sizes`: list at least one size".into()));
            }
            let mut out = Vec::new();
            for (i, s) in list.iter().enumerate() {
                out.push(meshes::parse_size(s).map_err(|e| key_err(format!("sizes[{i}]"), e))?);
            }
            let spelled: Vec<String> = out.iter().map(|(w, h)| format!("{w}x{h}")).collect();
            distinct_values("sizes", list, &spelled)?;
            out
        }
    };
    let views = expand_views(&cfg.views)?;
    let projections = match &cfg.projection {
        None => vec![Projection::Ortho],
        Some(p) => {
            if p.0.is_empty() {
                return Err(Error::Input(
                    "key `projection`: list at least one projection".into(),
                ));
            }
            let mut v = Vec::new();
            for s in &p.0 {
                v.push(Projection::parse(s).map_err(|e| key_err("projection", e))?);
            }
            let names: Vec<String> = v.iter().map(|p| p.name().to_string()).collect();
            distinct_values("projection", &p.0, &names)?;
            v
        }
    };
    bound(
        "views × sizes × projection (cells per variant)",
        views.len() * sizes.len() * projections.len(),
        1_000_000,
    )?;
    let repeats = cfg.repeats.unwrap_or(3);
    if repeats == 0 {
        return Err(Error::Input("key `repeats`: must be at least 1".into()));
    }
    for (i, p) in cfg.pairs.iter().enumerate() {
        for (k, l) in [("test", &p.test), ("reference", &p.reference)] {
            if !variants.iter().any(|v| &v.label == l) {
                return Err(Error::Input(format!(
                    "key `pairs[{i}].{k}`: '{l}' is not one of the variants ({})",
                    variants
                        .iter()
                        .map(|v| v.label.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
        }
    }
    Ok(Experiment {
        name: cfg.name.clone().unwrap_or_else(|| "experiment".into()),
        datasets: cfg.datasets,
        variants,
        sizes,
        views,
        projections,
        tf_name,
        tf,
        repeats,
        warmup: cfg.warmup.unwrap_or(1),
        error: cfg.error.unwrap_or(true),
        interleave: cfg.interleave.unwrap_or(false),
        save_images: cfg.save_images.unwrap_or(false),
        cache_dir: cfg.cache_dir,
        seed: cfg.seed.unwrap_or(meshes::DEFAULT_SEED),
        pairs: cfg.pairs,
        base_dir: base.to_path_buf(),
    })
}

/// A name safe as one path component (images are saved under `DIR/images/<dataset>/` in
/// files named after the variant): characters other than ASCII letters, digits, `-`, `.` and
/// `_` become `_`, and a name of dots only (`.`, `..`) becomes underscores. Different names may
/// meet in one (`x/y` and `x_y`): the experiment refuses datasets and variants that would.
pub fn sanitize(s: &str) -> String {
    let out: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if out.chars().all(|c| c == '.') {
        out.replace('.', "_")
    } else {
        out
    }
}

/// Refuses an empty name among `names` (of `what`s, the i-th given by the key `key(i)`), two
/// equal ones, and two that would be saved under one file name ([`sanitize`]): their rows or
/// images could not be told apart. Names both keys.
fn distinct(what: &str, names: &[String], key: impl Fn(usize) -> String) -> Result<()> {
    let mut seen: std::collections::BTreeMap<String, usize> = Default::default();
    let mut files: std::collections::BTreeMap<String, usize> = Default::default();
    for (i, n) in names.iter().enumerate() {
        if n.trim().is_empty() {
            return Err(Error::Input(format!(
                "key `{}`: the {what} has an empty name",
                key(i)
            )));
        }
        if let Some(&j) = seen.get(n) {
            return Err(Error::Input(format!(
                "keys `{}` and `{}` are both the {what} '{n}': their rows would share a key; give one a `label` of its own",
                key(j),
                key(i)
            )));
        }
        seen.insert(n.clone(), i);
        let f = sanitize(n);
        if let Some(&j) = files.get(&f) {
            return Err(Error::Input(format!(
                "keys `{}` and `{}`: the {what}s '{}' and '{n}' would save their images under one name '{f}'; rename one",
                key(j),
                key(i),
                names[j]
            )));
        }
        files.insert(f, i);
    }
    Ok(())
}

/// Refuses two entries of the list `key` (`given`, as written) that mean the same
/// (`meaning`, parallel: `16x16` and `16X16`), naming both.
fn distinct_values(key: &str, given: &[String], meaning: &[String]) -> Result<()> {
    for (i, m) in meaning.iter().enumerate() {
        if let Some(j) = meaning[..i].iter().position(|x| x == m) {
            return Err(Error::Input(format!(
                "key `{key}`: '{}' ({key}[{j}]) and '{}' ({key}[{i}]) are the same {m}; list it once",
                given[j], given[i]
            )));
        }
    }
    Ok(())
}

/// A renderer's `datasets` name datasets of the experiment, and an `analytic` yardstick has
/// an analytic field on each dataset it runs on.
fn check_renderer_datasets(r: &RendererSpec, datasets: &[DatasetSpec]) -> Result<()> {
    let names: Vec<String> = datasets.iter().map(DatasetSpec::display_name).collect();
    if let Some(only) = &r.datasets {
        for d in only {
            if !names.contains(d) {
                return Err(Error::Input(format!(
                    "datasets: '{d}' is not one of the experiment's datasets ({})",
                    names.join(", ")
                )));
            }
        }
    }
    let analytic = r
        .reference
        .as_deref()
        .is_some_and(|s| matches!(Yardstick::parse(s), Ok(Yardstick::Analytic(_))));
    if analytic {
        for (d, n) in datasets.iter().zip(&names) {
            let runs = r.datasets.as_ref().is_none_or(|o| o.contains(n));
            if runs && d.cells.is_none() {
                return Err(Error::Input(format!(
                    "reference: dataset '{n}' has no analytic field (build it with `cells` and `field`), or leave it out with `datasets`"
                )));
            }
        }
    }
    Ok(())
}

/// The transfer function an experiment uses when it names none (`default`).
pub fn default_tf() -> (String, TransferFunction) {
    let tf = TransferFunction::preset("default").expect("the default preset exists");
    ("default".into(), tf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_about_y_sweeps_azimuth() {
        let v = ViewsSpec {
            rotate: Some(RotateSpec {
                frames: 4,
                axis: "y".into(),
                start: Some("0,20".into()),
            }),
            ..Default::default()
        };
        let views = expand_views(&v).unwrap();
        let az: Vec<f64> = views.iter().map(|v| v.view.azimuth).collect();
        assert_eq!(az, vec![0.0, 270.0, 180.0, 90.0]);
        assert!(views.iter().all(|v| (v.view.elevation - 20.0).abs() < 1e-9));
    }

    /// An `optional` renderer that cannot be made becomes a variant that says why; the same
    /// entry without `optional` refuses the experiment.
    #[test]
    fn optional_renderer_that_cannot_run_is_kept_with_its_reason() {
        let spec = |optional| RendererSpec {
            name: "cpu-pt".into(),
            sorts: Some(vec!["bubble".into()]),
            integrators: Some(vec!["partial".into()]),
            optional,
            ..Default::default()
        };
        let expand = |r: &RendererSpec| expand_renderer(r, &default_tf(), Path::new("."));
        let v = expand(&spec(true)).unwrap();
        assert_eq!(v.len(), 1);
        assert_eq!(v[0].label, "cpu-pt/bubble/partial");
        assert!(v[0].unavailable.as_deref().unwrap().contains("bubble"));
        assert!(expand(&spec(false)).is_err());
        let ok = RendererSpec {
            sorts: None,
            ..spec(true)
        };
        assert!(expand(&ok).unwrap()[0].unavailable.is_none());
    }

    #[test]
    fn unknown_key_is_named() {
        let e = parse(
            "datasets = [\"spx\"]\nrenderers = [{ nam = \"raycast\" }]\n",
            "x.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("renderers[0]") && e.contains("nam"), "{e}");
        assert!(!e.contains('\n'));
    }
}
