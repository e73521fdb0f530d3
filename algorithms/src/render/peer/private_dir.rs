//! The private directory of one peer process: `tetbench-peer-PID-N` under the temporary
//! directory, mode 0700, removed when the peer ends. It holds a `.lock` file that its tetbench
//! keeps locked (`flock`) while it lives; a directory whose lock can be taken belongs to a run
//! that was killed, and the next run removes it ([`PrivateDir::create`]).

use std::fs::File;
use std::os::fd::AsRawFd;
use std::os::unix::fs::{DirBuilderExt, MetadataExt};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use crate::error::{Error, Result};

/// A private directory for one peer process (module docs).
pub struct PrivateDir {
    path: PathBuf,
    _lock: File,
}

static NEXT_DIR: AtomicU64 = AtomicU64::new(0);

const DIR_PREFIX: &str = "tetbench-peer-";

impl PrivateDir {
    /// Creates `BASE/tetbench-peer-PID-N` (mode 0700) and locks it; first removes the
    /// directories that killed runs left in `base`.
    pub fn create(base: &Path) -> Result<PrivateDir> {
        sweep_stale(base);
        loop {
            let path = base.join(format!(
                "{DIR_PREFIX}{}-{}",
                std::process::id(),
                NEXT_DIR.fetch_add(1, Ordering::Relaxed)
            ));
            match std::fs::DirBuilder::new().mode(0o700).create(&path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(Error::io(&path, e)),
            }
            let lock_path = path.join(".lock");
            let lock = File::create(&lock_path).map_err(|e| Error::io(&lock_path, e))?;
            // SAFETY: a valid open descriptor.
            unsafe {
                libc::flock(lock.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB);
            }
            return Ok(PrivateDir { path, _lock: lock });
        }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for PrivateDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// Removes the peer directories of runs that were killed: ours (this user's) whose lock can be
/// taken, or that have no lock file and are older than a minute (a directory is locked right
/// after it is made); and `tetbench-vtk-PID-N` directories (older versions' VTK helper) whose
/// process is gone.
fn sweep_stale(base: &Path) {
    let Ok(entries) = std::fs::read_dir(base) else {
        return;
    };
    // SAFETY: geteuid has no preconditions.
    let uid = unsafe { libc::geteuid() };
    for e in entries.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        let path = e.path();
        let Ok(meta) = std::fs::symlink_metadata(&path) else {
            continue;
        };
        if !meta.is_dir() || meta.uid() != uid {
            continue;
        }
        let stale = if name.starts_with(DIR_PREFIX) {
            match File::open(path.join(".lock")) {
                // SAFETY: a valid open descriptor; the lock is released when `f` closes.
                Ok(f) => unsafe { libc::flock(f.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) == 0 },
                Err(_) => meta
                    .modified()
                    .ok()
                    .and_then(|m| m.elapsed().ok())
                    .is_some_and(|age| age > Duration::from_secs(60)),
            }
        } else if let Some(rest) = name.strip_prefix("tetbench-vtk-") {
            rest.split('-')
                .next()
                .and_then(|p| p.parse::<i32>().ok())
                .is_some_and(|pid| !alive(pid))
        } else {
            false
        };
        if stale {
            let _ = std::fs::remove_dir_all(&path);
        }
    }
}

fn alive(pid: i32) -> bool {
    // SAFETY: signal 0 only checks that the process exists.
    pid > 0
        && (unsafe { libc::kill(pid, 0) } == 0
            || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH))
}
