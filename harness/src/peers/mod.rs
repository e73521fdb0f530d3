//! Peers in the command-line layer: which declarations a command may use, registered once
//! before any renderer is looked up ([`register`]), and the conformance suite ([`check`]).
//! (What each peer runs is printed before the first frame by `bench::announce_peers`.)
//!
//! Declarations come from the files named by `TETBENCH_PEERS` and `--peers` (the user's own)
//! and, for `bench`, from the experiment file's `[[peer]]` tables — used only with
//! `--allow-peers`, since an experiment file from someone else's artifact must not start
//! programs the user did not ask for.

pub mod check;

use std::path::{Path, PathBuf};

use algorithms::render::peer::{self, decl, PeerSpec};
use algorithms::{Error, Result};

/// Reads the declarations a command may use and registers them (once, before any lookup).
/// `experiment`: an experiment file whose own `[[peer]]` tables run only when `allow`.
pub fn register(files: &[PathBuf], experiment: Option<&Path>, allow: bool) -> Result<()> {
    let mut specs: Vec<PeerSpec> = Vec::new();
    let mut seen: Vec<PathBuf> = Vec::new();
    for f in decl::env_files().iter().chain(files) {
        // The same file named twice (in TETBENCH_PEERS and by --peers) is read once.
        let key = std::fs::canonicalize(f).unwrap_or_else(|_| f.clone());
        if seen.contains(&key) {
            continue;
        }
        seen.push(key);
        specs.extend(decl::load_file(f)?);
    }
    if let Some(path) = experiment {
        let own = experiment_peers(path)?;
        if !own.is_empty() && !allow {
            let cmds: Vec<String> = own
                .iter()
                .map(|s| format!("{}: `{}`", s.name, s.launch.command_line()))
                .collect();
            return Err(Error::Input(format!(
                "{} declares peers that would run programs ({}); pass --allow-peers to run them",
                path.display(),
                cmds.join("; ")
            )));
        }
        specs.extend(own);
    }
    peer::register(specs)
}

/// The `[[peer]]` tables of an experiment file (relative paths against its directory).
pub fn experiment_peers(path: &Path) -> Result<Vec<PeerSpec>> {
    let text = algorithms::io::read_input_string(path, algorithms::io::files::MAX_SETTINGS_BYTES)?;
    let origin = path.display().to_string();
    let cfg = crate::experiment::parse(&text, &origin)?;
    let base = decl::base_dir(path);
    cfg.peer.iter().map(|d| d.to_spec(&base, &origin)).collect()
}
