//! What every plugin kind (renderer, sort, integrator) shares, after Mitsuba's plugin
//! registries: the documented parameters a plugin declares in its info record, and the checks
//! of names against a registry ("did you mean …" for misspelled names).

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
