//! Transfer functions in experiment files: a preset name or a JSON file (CONVENTIONS §3), or a
//! table written in the file itself — the JSON's keys (`name`, `range`, `points`), or a preset
//! with its range fixed (`{ preset = "default", range = [0, 1] }`).

use std::fmt;
use std::path::Path;

use algorithms::tf::TfPoint;
use algorithms::{Error, Result, TransferFunction};
use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer};

/// A transfer function as an experiment file gives it.
#[derive(Debug, Clone, PartialEq)]
pub enum TfSpec {
    /// A preset name, or a JSON file relative to the experiment file.
    Named(String),
    /// Written out in the experiment file.
    Inline(TfTable),
}

/// The table form: either `points` (the JSON's keys) or a `preset` whose range is replaced.
#[derive(Deserialize, Debug, Clone, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct TfTable {
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default)]
    pub preset: Option<String>,
    #[serde(default)]
    pub range: Option<[f64; 2]>,
    #[serde(default)]
    pub points: Option<Vec<TfPoint>>,
}

impl TfSpec {
    /// An inline transfer function (from code building an experiment).
    pub fn inline(tf: &TransferFunction) -> TfSpec {
        TfSpec::Inline(TfTable {
            name: Some(tf.name.clone()),
            preset: None,
            range: tf.range,
            points: Some(tf.points.clone()),
        })
    }

    /// The validated transfer function; a file is resolved against `base`.
    pub fn resolve(&self, base: &Path) -> Result<TransferFunction> {
        match self {
            TfSpec::Named(name) => {
                let path = base.join(name);
                if TransferFunction::preset(name).is_none() && path.exists() {
                    TransferFunction::load(&path.display().to_string())
                } else {
                    TransferFunction::load(name)
                }
            }
            TfSpec::Inline(t) => {
                let mut tf = match (&t.preset, &t.points) {
                    (Some(p), None) => TransferFunction::preset(p).ok_or_else(|| {
                        Error::Input(format!(
                            "preset '{p}': no such preset (presets: {})",
                            algorithms::tf::PRESETS.join(", ")
                        ))
                    })?,
                    (None, Some(points)) => TransferFunction {
                        name: "inline".into(),
                        range: None,
                        points: points.clone(),
                    },
                    _ => {
                        return Err(Error::Input(
                            "give either `points` or a `preset`, not both or neither".into(),
                        ))
                    }
                };
                if let Some(n) = &t.name {
                    tf.name = n.clone();
                }
                if t.range.is_some() {
                    tf.range = t.range;
                }
                tf.validate(&tf.name.clone())?;
                Ok(tf)
            }
        }
    }
}

impl<'de> Deserialize<'de> for TfSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = TfSpec;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a preset name or JSON file, or a table { points = [...] } or { preset = ..., range = [...] }",
                )
            }
            fn visit_str<E: de::Error>(self, s: &str) -> std::result::Result<TfSpec, E> {
                Ok(TfSpec::Named(s.to_string()))
            }
            fn visit_map<A: MapAccess<'de>>(self, m: A) -> std::result::Result<TfSpec, A::Error> {
                TfTable::deserialize(de::value::MapAccessDeserializer::new(m)).map(TfSpec::Inline)
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_tables_and_presets_with_a_range() {
        let fixed = TfSpec::Inline(TfTable {
            preset: Some("default".into()),
            range: Some([0.0, 1.0]),
            ..Default::default()
        });
        let tf = fixed.resolve(Path::new(".")).unwrap();
        assert_eq!(tf.name, "default");
        assert_eq!(tf.range, Some([0.0, 1.0]));
        assert_eq!(
            tf.points,
            TransferFunction::preset("default").unwrap().points
        );
        let back = TfSpec::inline(&tf).resolve(Path::new(".")).unwrap();
        assert_eq!(back, tf);
        let both = TfSpec::Inline(TfTable {
            preset: Some("default".into()),
            points: Some(tf.points.clone()),
            ..Default::default()
        });
        assert!(both.resolve(Path::new(".")).is_err());
        let bad = TfSpec::Inline(TfTable {
            points: Some(vec![]),
            ..Default::default()
        });
        assert!(bad.resolve(Path::new(".")).is_err());
    }
}
