//! What every plugin kind (renderer, sort, integrator) shares, after Mitsuba's plugin
//! registries: the documented parameters a plugin declares in its info record, read through
//! [`Params`], and the checks of names against a registry ("did you mean …" for misspelled
//! names).

use crate::error::{Error, Result};

/// One parameter a plugin takes, documented where the plugin is defined.
#[derive(Clone, Copy, Debug)]
pub struct ParamInfo {
    pub name: &'static str,
    /// The value used when the parameter is not given ("" when absent means "off").
    pub default: &'static str,
    /// What it does and which values it takes.
    pub doc: &'static str,
}

/// Checks `KEY=VALUE` parameters against the declared ones: every key must be declared, and
/// none may be given twice. `owner` names the plugin in the message.
pub fn check_params(owner: &str, declared: &[ParamInfo], given: &[(String, String)]) -> Result<()> {
    let names: Vec<&str> = declared.iter().map(|p| p.name).collect();
    for (i, (k, _)) in given.iter().enumerate() {
        if !names.contains(&k.as_str()) {
            return Err(Error::Input(format!(
                "{owner}: unknown parameter '{k}' ({}){}",
                if names.is_empty() {
                    "it takes none".to_string()
                } else {
                    format!("it takes: {}", names.join(", "))
                },
                did_you_mean(k, &names)
            )));
        }
        if given[..i].iter().any(|(k2, _)| k2 == k) {
            return Err(Error::Input(format!(
                "{owner}: parameter '{k}' given twice"
            )));
        }
    }
    Ok(())
}

/// A plugin's parameters as given (`KEY=VALUE`), checked once against the declared ones, with
/// typed getters whose defaults come from the plugin's [`ParamInfo`] (pbrt-v4's
/// `ParameterDictionary`): a plugin never writes a default or parses a value by hand. A value
/// that does not parse is one line, `"{owner}: parameter {key}={value}: expected …"`.
#[derive(Clone, Debug)]
pub struct Params {
    owner: String,
    declared: &'static [ParamInfo],
    given: Vec<(String, String)>,
}

impl Params {
    /// Checks `given` against `declared` ([`check_params`]: every key declared, none twice);
    /// `owner` names the plugin in messages.
    pub fn new(
        owner: &str,
        declared: &'static [ParamInfo],
        given: &[(String, String)],
    ) -> Result<Params> {
        check_params(owner, declared, given)?;
        Ok(Params {
            owner: owner.to_string(),
            declared,
            given: given.to_vec(),
        })
    }

    /// The text of `key`: the given value, else the declared default. Panics on a key the
    /// plugin did not declare (a bug in the plugin, never bad input).
    pub fn text(&self, key: &str) -> &str {
        let info = self
            .declared
            .iter()
            .find(|p| p.name == key)
            .unwrap_or_else(|| panic!("{}: parameter '{key}' is not declared", self.owner));
        self.given
            .iter()
            .find(|(k, _)| k == key)
            .map_or(info.default, |(_, v)| v.as_str())
    }

    /// Whether `key` has a value, given or by default (a default of `""` means "off").
    pub fn is_set(&self, key: &str) -> bool {
        !self.text(key).is_empty()
    }

    /// The error for `key`'s value: `what` says what was expected.
    pub fn bad(&self, key: &str, what: &str) -> Error {
        Error::Input(format!(
            "{}: parameter {key}={}: {what}",
            self.owner,
            self.text(key)
        ))
    }

    /// `key` as one of `choices` (name, value).
    pub fn choice<T: Copy>(&self, key: &str, choices: &[(&str, T)]) -> Result<T> {
        let v = self.text(key);
        choices
            .iter()
            .find(|(n, _)| *n == v)
            .map(|c| c.1)
            .ok_or_else(|| {
                let names: Vec<&str> = choices.iter().map(|c| c.0).collect();
                self.bad(key, &format!("expected one of {}", names.join(", ")))
            })
    }

    /// `key` as a number in `range`.
    pub fn f64_in(&self, key: &str, range: std::ops::RangeInclusive<f64>) -> Result<f64> {
        self.text(key)
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| range.contains(v))
            .ok_or_else(|| {
                self.bad(
                    key,
                    &format!("expected a number in [{}, {}]", range.start(), range.end()),
                )
            })
    }

    /// `key` as a finite number above 0.
    pub fn positive_f64(&self, key: &str) -> Result<f64> {
        self.text(key)
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v > 0.0)
            .ok_or_else(|| self.bad(key, "expected a positive number"))
    }

    /// `key` as an integer in `range`.
    pub fn usize_in(&self, key: &str, range: std::ops::RangeInclusive<usize>) -> Result<usize> {
        self.text(key)
            .trim()
            .parse::<usize>()
            .ok()
            .filter(|v| range.contains(v))
            .ok_or_else(|| {
                self.bad(
                    key,
                    &format!("expected an integer in {}..={}", range.start(), range.end()),
                )
            })
    }

    /// `key` as an integer in `range`, or `None` when it is not set.
    pub fn opt_usize_in(
        &self,
        key: &str,
        range: std::ops::RangeInclusive<usize>,
    ) -> Result<Option<usize>> {
        if !self.is_set(key) {
            return Ok(None);
        }
        self.usize_in(key, range).map(Some)
    }

    /// `key` as a switch: `1`/`true` or `0`/`false`.
    pub fn flag(&self, key: &str) -> Result<bool> {
        self.choice(
            key,
            &[("1", true), ("true", true), ("0", false), ("false", false)],
        )
    }

    /// `key` as a comma-separated list of 1 to `max` items, each read by `item`; empty when
    /// it is not set. `what` describes an item for the message.
    pub fn list<T>(
        &self,
        key: &str,
        max: usize,
        what: &str,
        item: impl Fn(&str) -> Option<T>,
    ) -> Result<Vec<T>> {
        if !self.is_set(key) {
            return Ok(Vec::new());
        }
        let v = self
            .text(key)
            .split(',')
            .map(|x| item(x.trim()))
            .collect::<Option<Vec<T>>>()
            .ok_or_else(|| self.bad(key, &format!("expected a comma-separated list of {what}")))?;
        if v.len() > max {
            return Err(self.bad(key, &format!("1 to {max} values")));
        }
        Ok(v)
    }
}

/// Edit distance between two strings, by characters: insertions, deletions, substitutions and
/// swaps of two neighbours each cost 1 (optimal string alignment).
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let w = b.len() + 1;
    let mut d = vec![0usize; (a.len() + 1) * w];
    for i in 0..=a.len() {
        for j in 0..=b.len() {
            d[i * w + j] = if i == 0 || j == 0 {
                i + j
            } else {
                let mut v = (d[(i - 1) * w + j] + 1)
                    .min(d[i * w + j - 1] + 1)
                    .min(d[(i - 1) * w + j - 1] + usize::from(a[i - 1] != b[j - 1]));
                if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                    v = v.min(d[(i - 2) * w + j - 2] + 1);
                }
                v
            };
        }
    }
    d[a.len() * w + b.len()]
}

/// `"; did you mean 'x'?"` when one of `known` is close to `name` (at most a third of its
/// letters off, at least one), else `""`: ready to append to an "unknown name" message.
pub fn did_you_mean(name: &str, known: &[&str]) -> String {
    let limit = (name.chars().count() / 3).max(1);
    known
        .iter()
        .map(|k| (edit_distance(name, k), *k))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, _)| d)
        .map(|(_, k)| format!("; did you mean '{k}'?"))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggests_only_close_names() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("mdoe", "mode"), 1);
        assert_eq!(
            did_you_mean("raycats", &["raycast", "cpu-pt"]),
            "; did you mean 'raycast'?"
        );
        assert_eq!(did_you_mean("zzz", &["raycast", "cpu-pt"]), "");
    }

    #[test]
    fn params_are_checked_against_the_declared_list() {
        const P: &[ParamInfo] = &[ParamInfo {
            name: "mode",
            default: "dvr",
            doc: "",
        }];
        let kv = |k: &str| (k.to_string(), "1".to_string());
        assert!(check_params("x", P, &[kv("mode")]).is_ok());
        let e = check_params("x", P, &[kv("mdoe")]).unwrap_err().to_string();
        assert!(
            e.contains("unknown parameter 'mdoe'") && e.contains("did you mean 'mode'"),
            "{e}"
        );
        assert!(check_params("x", &[], &[kv("bogus")]).is_err());
        let e = check_params("x", P, &[kv("mode"), kv("mode")])
            .unwrap_err()
            .to_string();
        assert!(e.contains("twice"), "{e}");
    }
}
