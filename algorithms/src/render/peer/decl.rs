//! `[[peer]]` declarations (TOML): in peers files (`TETBENCH_PEERS`, `--peers FILE`) and in
//! experiment files. Each table becomes a [`PeerSpec`]; every error is one line naming the file
//! and the peer.
//!
//! ```toml
//! [[peer]]
//! name = "numpy-raycast"
//! command = ["python3", "python/numpy_raycast.py"]   # started in this file's directory
//! family = "raycasting"                               # pt | raycasting | other
//! integrators = ["average", "partial"]                # the first is its default
//! description = "a ray caster in numpy"
//! timeout_s = 120                                     # per request (default 120)
//! env = { PYTHONPATH = "../python" }                  # optional
//! params = [{ name = "chunk", default = "1048576", doc = "pairs per batch" }]  # optional
//! ```

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::Deserialize;

use super::{Launch, PeerFamily, PeerParam, PeerSpec, DEFAULT_TIMEOUT};
use crate::error::{Error, Result};

/// One `[[peer]]` table as written.
#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct PeerDecl {
    pub name: String,
    pub command: Vec<String>,
    pub family: String,
    pub integrators: Vec<String>,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub timeout_s: Option<f64>,
    #[serde(default)]
    pub env: BTreeMap<String, String>,
    #[serde(default)]
    pub params: Vec<ParamDecl>,
}

/// One parameter of a peer.
#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ParamDecl {
    pub name: String,
    #[serde(default)]
    pub default: String,
    #[serde(default)]
    pub doc: String,
}

/// A peers file: `[[peer]]` tables and nothing else.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PeersFile {
    #[serde(default)]
    peer: Vec<PeerDecl>,
}

/// The longest timeout a declaration may ask for (a day).
const MAX_TIMEOUT_S: f64 = 86_400.0;

impl PeerDecl {
    /// Checks the table and makes its spec. Relative paths in `command[0]` are resolved against
    /// `base` (the declaring file's directory), where the peer also starts.
    pub fn to_spec(&self, base: &Path, origin: &str) -> Result<PeerSpec> {
        let what = format!("{origin}: peer '{}'", self.name);
        let bad = |m: String| Error::Input(format!("{what}: {m}"));
        check_name(&self.name).map_err(|m| Error::Input(format!("{origin}: {m}")))?;
        let Some((program, args)) = self.command.split_first() else {
            return Err(bad(
                "`command` is empty (it is the argv array to run)".into()
            ));
        };
        if program.is_empty() {
            return Err(bad("`command`'s program is empty".into()));
        }
        let family = PeerFamily::parse(&self.family).ok_or_else(|| {
            bad(format!(
                "family '{}' is not one of pt, raycasting, other",
                self.family
            ))
        })?;
        if self.integrators.is_empty() {
            return Err(bad("`integrators` is empty (name at least one)".into()));
        }
        for (i, integ) in self.integrators.iter().enumerate() {
            crate::optics::info(integ).map_err(|e| bad(e.to_string()))?;
            if self.integrators[..i].contains(integ) {
                return Err(bad(format!("integrator '{integ}' listed twice")));
            }
        }
        let timeout = match self.timeout_s {
            None => DEFAULT_TIMEOUT,
            Some(t) if t.is_finite() && t > 0.0 && t <= MAX_TIMEOUT_S => Duration::from_secs_f64(t),
            Some(t) => {
                return Err(bad(format!(
                    "timeout_s = {t}: expected seconds in (0, {MAX_TIMEOUT_S}]"
                )))
            }
        };
        let mut params: Vec<PeerParam> = Vec::new();
        for p in &self.params {
            check_name(&p.name).map_err(|m| bad(format!("parameter: {m}")))?;
            if params.iter().any(|q| q.name == p.name) {
                return Err(bad(format!("parameter '{}' declared twice", p.name)));
            }
            params.push(PeerParam {
                name: p.name.clone(),
                default: p.default.clone(),
                doc: p.doc.clone(),
            });
        }
        let program_path = Path::new(program);
        let program: OsString = if program_path.is_relative() && program.contains('/') {
            base.join(program_path).into_os_string()
        } else {
            program.into()
        };
        Ok(PeerSpec {
            name: self.name.clone(),
            description: self.description.clone(),
            family,
            integrators: self.integrators.clone(),
            params,
            timeout,
            launch: Launch {
                program,
                args: args.iter().map(OsString::from).collect(),
                cwd: Some(base.to_path_buf()),
                env: self
                    .env
                    .iter()
                    .map(|(k, v)| (OsString::from(k), OsString::from(v)))
                    .collect(),
                files: Vec::new(),
            },
            origin: origin.to_string(),
        })
    }
}

/// A peer or parameter name: letters, digits, `-`, `_` and `.`, starting with a letter or
/// digit (so it can never read as a flag, a wrapper `jbu:…@…` or a path).
fn check_name(name: &str) -> std::result::Result<(), String> {
    let ok = name.len() <= 64
        && name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphanumeric())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c));
    if ok {
        Ok(())
    } else {
        Err(format!(
            "name {name:?}: use up to 64 letters, digits, '-', '_' or '.', starting with a letter or digit"
        ))
    }
}

/// The directory a declaring file's relative paths are resolved against.
pub fn base_dir(file: &Path) -> PathBuf {
    let dir = file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf())
}

/// Reads a peers file (`[[peer]]` tables only).
pub fn load_file(path: &Path) -> Result<Vec<PeerSpec>> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::Input(format!(
            "{}: not a regular file",
            path.display()
        )));
    }
    if meta.len() > 1 << 20 {
        return Err(Error::Input(format!(
            "{}: {} bytes; a peers file is at most 1 MiB",
            path.display(),
            meta.len()
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let origin = path.display().to_string();
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let file: PeersFile = toml::from_str(text).map_err(|e| toml_error(&origin, text, &e))?;
    let base = base_dir(path);
    file.peer
        .iter()
        .map(|d| d.to_spec(&base, &origin))
        .collect()
}

/// A TOML error as one line: `FILE:LINE: message`.
pub fn toml_error(origin: &str, text: &str, e: &toml::de::Error) -> Error {
    let line = e
        .span()
        .map(|s| {
            format!(
                ":{}",
                text[..s.start.min(text.len())].matches('\n').count() + 1
            )
        })
        .unwrap_or_default();
    Error::Input(format!(
        "{origin}{line}: {}",
        e.message().split_whitespace().collect::<Vec<_>>().join(" ")
    ))
}

/// The peers files named by `TETBENCH_PEERS` (colon-separated; empty entries skipped).
pub fn env_files() -> Vec<PathBuf> {
    std::env::var_os("TETBENCH_PEERS")
        .map(|v| {
            std::env::split_paths(&v)
                .filter(|p| !p.as_os_str().is_empty())
                .collect()
        })
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decl(text: &str) -> Result<Vec<PeerSpec>> {
        let file: PeersFile = toml::from_str(text).map_err(|e| toml_error("t.toml", text, &e))?;
        file.peer
            .iter()
            .map(|d| d.to_spec(Path::new("/base"), "t.toml"))
            .collect()
    }

    #[test]
    fn a_declaration_becomes_a_spec() {
        let s = decl(
            r#"
[[peer]]
name = "np"
command = ["bin/np", "--fast"]
family = "raycasting"
integrators = ["partial", "average"]
timeout_s = 5
env = { A = "b" }
"#,
        )
        .unwrap();
        assert_eq!(s.len(), 1);
        let s = &s[0];
        assert_eq!(s.family, PeerFamily::RayCasting);
        assert_eq!(s.integrators, ["partial", "average"]);
        assert_eq!(s.timeout, Duration::from_secs(5));
        assert_eq!(s.launch.program, OsString::from("/base/bin/np"));
        assert_eq!(s.launch.cwd.as_deref(), Some(Path::new("/base")));
        assert_eq!(s.launch.command_line(), "/base/bin/np --fast");
    }

    #[test]
    fn bad_declarations_are_one_line_naming_the_problem() {
        let base = "[[peer]]\nname = \"p\"\ncommand = [\"x\"]\nfamily = \"pt\"\nintegrators = [\"average\"]\n";
        for (extra, want) in [
            ("timeout_s = 0\n", "timeout_s = 0"),
            ("timeout_s = nan\n", "timeout_s = NaN"),
            ("colour = 1\n", "unknown field `colour`"),
        ] {
            let e = decl(&format!("{base}{extra}")).unwrap_err().to_string();
            assert!(e.contains(want) && !e.contains('\n'), "{e}");
        }
        for (from, to, want) in [
            ("\"pt\"", "\"splat\"", "family 'splat'"),
            ("[\"average\"]", "[\"fast\"]", "unknown integrator 'fast'"),
            ("[\"average\"]", "[]", "`integrators` is empty"),
            ("[\"x\"]", "[]", "`command` is empty"),
            ("\"p\"", "\"jbu:raycast@64\"", "name \"jbu:raycast@64\""),
            ("\"p\"", "\"-rf\"", "name \"-rf\""),
        ] {
            let e = decl(&base.replacen(from, to, 1)).unwrap_err().to_string();
            assert!(e.contains(want) && !e.contains('\n'), "{e}");
        }
    }
}
