//! A sweep's state on disk: which shard of the measurement matrix a run measures, the shard's
//! identity file (`DIR/shard.txt`, checked by `tetbench merge` and `--resume`), the lock that
//! keeps two runs out of one `--out`, and the rows already measured (for `--resume`).
//!
//! Shards are balanced by estimated cost, tets × pixels × frames, with the longest-first greedy
//! rule (each unit, in decreasing cost, goes to the least-loaded shard; ties to the lower index),
//! which every shard computes the same way from the same experiment, so they agree without
//! talking to each other.

use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};

use algorithms::{Error, Result};

use crate::rows::Row;

/// One shard of N: `I/N` with 0 ≤ I < N.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// The whole sweep.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Parses `I/N` (the `--shard` flag); one line naming what is wrong.
    pub fn parse(s: &str) -> Result<Shard> {
        Shard::parse_as(s, "--shard")
    }

    /// Parses `I/N` given as `what` (a flag, or a line of a file), named in the error.
    pub fn parse_as(s: &str, what: &str) -> Result<Shard> {
        let bad = |why: &str| Error::Input(format!("{what} '{s}': {why}"));
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| bad("expected I/N, e.g. 0/4"))?;
        let parse = |x: &str, what: &str| {
            x.trim().parse::<usize>().map_err(|_| {
                bad(&format!(
                    "{what} '{x}' is not a whole number (expected I/N, e.g. 0/4)"
                ))
            })
        };
        let (index, count) = (parse(i, "I")?, parse(n, "N")?);
        if count == 0 {
            return Err(bad("N must be at least 1"));
        }
        if count > 100_000 {
            return Err(bad("N must be at most 100000"));
        }
        if index >= count {
            return Err(bad(&format!(
                "I must be below N (shards are numbered 0..{})",
                count - 1
            )));
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Assigns units of the given costs to `n` shards, continuing from the shards' `loads` (so a
/// sweep assigned dataset by dataset stays balanced overall). Longest first, least loaded wins,
/// ties to the lower shard and the earlier unit: the same on every machine.
pub fn assign(costs: &[f64], loads: &mut [f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..costs.len()).collect();
    order.sort_by(|&a, &b| costs[b].total_cmp(&costs[a]).then(a.cmp(&b)));
    let mut out = vec![0; costs.len()];
    for u in order {
        let (s, _) = loads
            .iter()
            .enumerate()
            .fold(
                (0, f64::INFINITY),
                |best, (i, &l)| {
                    if l < best.1 {
                        (i, l)
                    } else {
                        best
                    }
                },
            );
        loads[s] += costs[u];
        out[u] = s;
    }
    out
}

/// The key that names one row of a sweep, from its dataset, variant, projection, size and
/// view: no two rows of a run share it (the experiment refuses duplicates of each part), and
/// no two different rows can spell the same key (`|` and `\` inside a part are escaped).
pub fn cell_key(
    dataset: &str,
    variant: &str,
    projection: &str,
    (w, h): (u32, u32),
    view_id: &str,
) -> String {
    let esc = |s: &str| s.replace('\\', "\\\\").replace('|', "\\|");
    format!(
        "{}|{}|{}|{w}x{h}|{}",
        esc(dataset),
        esc(variant),
        esc(projection),
        esc(view_id)
    )
}

/// The key of a measured row (see [`cell_key`]).
pub fn row_key(r: &Row) -> String {
    cell_key(
        &r.dataset,
        &r.variant,
        &r.projection,
        (r.width, r.height),
        &r.view_id,
    )
}

/// blake3 of a set of row keys, in sorted order: what `shard.txt` records of a sweep's rows,
/// for `merge` to check that the merged rows are exactly the sweep's.
pub fn keys_hash<'a>(keys: impl IntoIterator<Item = &'a String>) -> String {
    let sorted: BTreeSet<&String> = keys.into_iter().collect();
    let mut h = blake3::Hasher::new();
    for k in sorted {
        h.update(&(k.len() as u64).to_le_bytes());
        h.update(k.as_bytes());
    }
    h.finalize().to_hex().to_string()
}

/// Whether a row is a failed measurement (its times are NaN and its note says why).
pub fn failed(r: &Row) -> bool {
    r.total_ms.is_nan()
}

/// Whether a measured row was to have its error against a yardstick but has none (the
/// yardstick could not be made or read; its note says why). Such a run ends with exit 3, as
/// one with failed rows does.
pub fn error_missing(r: &Row) -> bool {
    !failed(r) && !r.reference.is_empty() && r.rmse.is_none()
}

/// `DIR/shard.txt`: what a shard directory holds, for `merge` and `--resume` to check.
#[derive(Clone, Debug, PartialEq)]
pub struct ShardInfo {
    /// blake3 of the experiment file's bytes.
    pub experiment: String,
    pub shard: Shard,
    /// The tetbench version that measured it.
    pub version: String,
    /// Rows this shard measures and rows the whole (unsharded) sweep has; written when the
    /// run finishes (absent while it runs).
    pub rows: Option<(usize, usize)>,
    /// [`keys_hash`] of this shard's rows and of the whole sweep's; written when the run
    /// finishes.
    pub keys: Option<(String, String)>,
}

pub const SHARD_FILE: &str = "shard.txt";

/// blake3 of an experiment file, the identity `merge` and `--resume` compare.
pub fn experiment_hash(path: &Path) -> Result<String> {
    let bytes = algorithms::io::read_input(path, algorithms::io::files::MAX_SETTINGS_BYTES)?;
    Ok(blake3::hash(&bytes).to_hex().to_string())
}

impl ShardInfo {
    pub fn write(&self, dir: &Path) -> Result<()> {
        let p = dir.join(SHARD_FILE);
        let mut text = format!(
            "experiment: {}\nshard: {}\nversion: {}\n",
            self.experiment, self.shard, self.version
        );
        if let Some((mine, total)) = self.rows {
            text.push_str(&format!("rows: {mine}\nrows_total: {total}\n"));
        }
        if let Some((mine, all)) = &self.keys {
            text.push_str(&format!("keys: {mine}\nkeys_total: {all}\n"));
        }
        algorithms::io::atomic_write(&p, |w| w.write_all(text.as_bytes()))
    }

    /// Reads `DIR/shard.txt`; None when there is none.
    pub fn read(dir: &Path) -> Result<Option<ShardInfo>> {
        let p = dir.join(SHARD_FILE);
        if std::fs::symlink_metadata(&p).is_err() {
            return Ok(None);
        }
        let text = algorithms::io::read_input_string(&p, 1 << 20)?;
        let bad = || Error::Input(format!("{}: not a tetbench shard file", p.display()));
        let field = |k: &str| {
            text.lines()
                .find_map(|l| l.strip_prefix(k).and_then(|r| r.strip_prefix(": ")))
                .map(str::to_string)
        };
        let num = |k: &str| field(k).and_then(|v| v.parse::<usize>().ok());
        let rows = match (num("rows"), num("rows_total")) {
            (Some(a), Some(b)) => Some((a, b)),
            _ => None,
        };
        let shard = field("shard").ok_or_else(bad)?;
        let shard = Shard::parse_as(&shard, "shard:").map_err(|e| match e {
            Error::Input(m) => Error::Input(format!("{}: {m}", p.display())),
            o => o,
        })?;
        let keys = match (field("keys"), field("keys_total")) {
            (Some(a), Some(b)) => Some((a, b)),
            _ => None,
        };
        Ok(Some(ShardInfo {
            experiment: field("experiment").ok_or_else(bad)?,
            shard,
            version: field("version").ok_or_else(bad)?,
            rows,
            keys,
        }))
    }
}

/// A lock on an output directory: an exclusive `flock` on `DIR/.lock`, which holds the
/// owner's pid and host for the message a second run gets. The kernel drops the lock when its
/// process ends however it ends (SIGKILL, a node's crash seen through the file server), so a
/// lock is never stale: there is nothing to take over, two runs racing for it cannot both win,
/// and a pid reused by an unrelated process means nothing. Removed on drop.
pub struct Lock {
    path: PathBuf,
    _file: std::fs::File,
}

impl Lock {
    pub fn take(dir: &Path) -> Result<Lock> {
        use std::os::fd::AsRawFd;
        let path = dir.join(".lock");
        // Whoever removes the file (an owner dropping its lock) may do so between our open and
        // our flock: then we hold a lock on a file that is no longer `.lock`, so check and try
        // again.
        for _ in 0..100 {
            let mut f = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(|e| Error::io(&path, e))?;
            // SAFETY: flock on a descriptor we own; LOCK_NB never blocks.
            let r = unsafe { libc::flock(f.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
            if r != 0 {
                let err = std::io::Error::last_os_error();
                if err.raw_os_error() != Some(libc::EWOULDBLOCK) {
                    return Err(Error::io(&path, err));
                }
                let mut owner = String::new();
                use std::io::Read;
                let _ = (&mut f).take(4096).read_to_string(&mut owner);
                let owner = owner.trim();
                return Err(Error::Input(format!(
                    "{}: another tetbench run ({}) is writing into this directory; wait for it or choose another --out",
                    dir.display(),
                    if owner.is_empty() { "starting" } else { owner }
                )));
            }
            if !same_file(&f, &path) {
                continue;
            }
            let me = format!(
                "pid {} on {}",
                std::process::id(),
                algorithms::io::files::host_name()
            );
            f.set_len(0).map_err(|e| Error::io(&path, e))?;
            f.write_all(me.as_bytes())
                .and_then(|_| f.flush())
                .map_err(|e| Error::io(&path, e))?;
            return Ok(Lock { path, _file: f });
        }
        Err(Error::Input(format!(
            "{}: could not take the lock {}",
            dir.display(),
            path.display()
        )))
    }
}

/// Whether the open file `f` is still the one at `path`.
fn same_file(f: &std::fs::File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (f.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        // Removed while still held (the file closes after this), so that no run can lock this
        // file after us and believe it owns the directory while another locks a new `.lock`.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Removes the temporary files killed writers left under `dir`, recursively (see
/// [`algorithms::io::files::is_stale_temp`]: on a directory several machines share, another
/// machine's are left alone until they are old).
pub fn clean_stale_tmp(dir: &Path) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        let Ok(ft) = e.file_type() else { continue };
        if ft.is_dir() {
            clean_stale_tmp(&p);
            continue;
        }
        let name = e.file_name().to_string_lossy().to_string();
        let modified = e.metadata().ok().and_then(|m| m.modified().ok());
        if algorithms::io::files::is_stale_temp(&name, modified) {
            let _ = std::fs::remove_file(&p);
        }
    }
}

/// Rows already in `results.csv`, for `--resume`. A torn last line (a run killed while writing
/// it) is cut off the file, with a note; the keys of the complete rows are returned.
pub fn existing_rows(csv: &Path) -> Result<(Vec<Row>, Option<String>)> {
    if !csv.exists() {
        return Ok((Vec::new(), None));
    }
    let len = algorithms::io::open_input(csv)?
        .metadata()
        .map_err(|e| Error::io(csv, e))?
        .len();
    let mut note = None;
    if let Some(keep) = torn_tail(csv, len)? {
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(csv)
            .map_err(|e| Error::io(csv, e))?;
        f.set_len(keep).map_err(|e| Error::io(csv, e))?;
        note = Some(format!(
            "{}: dropped a torn last line ({} bytes) left by an interrupted run",
            csv.display(),
            len - keep
        ));
    }
    let meta = std::fs::metadata(csv).map_err(|e| Error::io(csv, e))?;
    if meta.len() == 0 {
        return Ok((Vec::new(), note));
    }
    Ok((crate::rows::read_rows(csv)?, note))
}

/// Where the complete rows of a CSV file of `len` bytes end, when its last line is torn (does
/// not end in a newline): the file is read back from its end, at most one line's worth
/// ([`crate::rows::MAX_CSV_LINE`]).
fn torn_tail(csv: &Path, len: u64) -> Result<Option<u64>> {
    use std::io::{Read, Seek, SeekFrom};
    if len == 0 {
        return Ok(None);
    }
    let mut f = algorithms::io::open_input(csv)?;
    let window = len.min(crate::rows::MAX_CSV_LINE as u64 + 1);
    f.seek(SeekFrom::Start(len - window))
        .map_err(|e| Error::io(csv, e))?;
    let mut tail = Vec::new();
    f.take(window)
        .read_to_end(&mut tail)
        .map_err(|e| Error::io(csv, e))?;
    if tail.ends_with(b"\n") {
        return Ok(None);
    }
    match tail.iter().rposition(|&b| b == b'\n') {
        Some(i) => Ok(Some(len - window + i as u64 + 1)),
        None if window == len => Ok(Some(0)),
        None => Err(Error::Input(format!(
            "{}: its last line is longer than {} bytes: not a tetbench results file",
            csv.display(),
            crate::rows::MAX_CSV_LINE
        ))),
    }
}

/// The keys of some rows.
pub fn keys(rows: &[Row]) -> BTreeSet<String> {
    rows.iter().map(row_key).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_parse_refuses_bad_input_in_one_line() {
        assert_eq!(Shard::parse("1/3").unwrap(), Shard { index: 1, count: 3 });
        for bad in ["3/3", "0/0", "a/b", "1", "-1/2", "1/3/4"] {
            let e = Shard::parse(bad).unwrap_err().to_string();
            assert!(e.contains(bad) && !e.contains('\n'), "{bad}: {e}");
        }
    }

    /// Runs racing for a directory whose lock file a dead run left: exactly one gets it, every
    /// time (threads here: each `Lock::take` is its own open file, as another process's is).
    #[test]
    fn racing_runs_never_both_take_the_lock() {
        let d = std::env::temp_dir().join(format!("tetbench-lockrace-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        for _ in 0..200 {
            std::fs::write(d.join(".lock"), "999999999\n").unwrap();
            let start = std::sync::Barrier::new(6);
            let done = std::sync::Barrier::new(6);
            let won = std::sync::atomic::AtomicUsize::new(0);
            std::thread::scope(|s| {
                for _ in 0..6 {
                    s.spawn(|| {
                        start.wait();
                        let l = Lock::take(&d);
                        if l.is_ok() {
                            won.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                        }
                        // Every taker holds its lock until all have tried.
                        done.wait();
                        drop(l);
                    });
                }
            });
            assert_eq!(won.into_inner(), 1);
        }
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn assign_balances_cost_not_count() {
        // One big unit and many small ones: the big one gets a shard to itself.
        let mut costs = vec![100.0];
        costs.extend(std::iter::repeat_n(1.0, 100));
        let mut loads = vec![0.0; 2];
        let a = assign(&costs, &mut loads);
        assert_eq!(a[0], 0);
        assert!(a[1..].iter().all(|&s| s == 1));
        assert_eq!(loads, vec![100.0, 100.0]);
        // Deterministic.
        let mut l2 = vec![0.0; 2];
        assert_eq!(assign(&costs, &mut l2), a);
    }
}
