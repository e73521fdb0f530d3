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

    /// Parses `I/N`; one line naming what is wrong.
    pub fn parse(s: &str) -> Result<Shard> {
        let bad = |why: &str| Error::Input(format!("--shard '{s}': {why}"));
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

/// The key that names one row of a sweep: no two rows of a run share it.
pub fn row_key(r: &Row) -> String {
    format!(
        "{}|{}|{}|{}x{}|{}",
        r.dataset, r.variant, r.projection, r.width, r.height, r.view_id
    )
}

/// Whether a row is a failed measurement (its times are NaN and its note says why).
pub fn failed(r: &Row) -> bool {
    r.total_ms.is_nan()
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
    /// run finishes ("" while it runs).
    pub rows: Option<(usize, usize)>,
}

pub const SHARD_FILE: &str = "shard.txt";

/// blake3 of an experiment file, the identity `merge` and `--resume` compare.
pub fn experiment_hash(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
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
        algorithms::io::atomic_write(&p, |w| w.write_all(text.as_bytes()))
    }

    /// Reads `DIR/shard.txt`; None when there is none.
    pub fn read(dir: &Path) -> Result<Option<ShardInfo>> {
        let p = dir.join(SHARD_FILE);
        if !p.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&p).map_err(|e| Error::io(&p, e))?;
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
        Ok(Some(ShardInfo {
            experiment: field("experiment").ok_or_else(bad)?,
            shard: Shard::parse(&field("shard").ok_or_else(bad)?)?,
            version: field("version").ok_or_else(bad)?,
            rows,
        }))
    }
}

/// A lock on an output directory: `DIR/.lock` holding the owner's pid, removed on drop. A lock
/// left by a process that no longer runs (SIGKILL) is taken over.
pub struct Lock {
    path: PathBuf,
}

impl Lock {
    pub fn take(dir: &Path) -> Result<Lock> {
        let path = dir.join(".lock");
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    let _ = writeln!(f, "{}", std::process::id());
                    return Ok(Lock { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let pid = std::fs::read_to_string(&path)
                        .ok()
                        .and_then(|s| s.trim().parse::<i32>().ok());
                    if let Some(pid) = pid.filter(|&p| alive(p)) {
                        return Err(Error::Input(format!(
                            "{}: another tetbench run (pid {pid}) is writing into this directory; wait for it or choose another --out",
                            dir.display()
                        )));
                    }
                    // Stale (its owner is gone, or it is still being written): take it over.
                    let _ = std::fs::remove_file(&path);
                }
                Err(e) => return Err(Error::io(&path, e)),
            }
        }
        Err(Error::Input(format!(
            "{}: could not take the lock {}",
            dir.display(),
            path.display()
        )))
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

fn alive(pid: i32) -> bool {
    if pid <= 0 {
        return false;
    }
    // SAFETY: signal 0 only checks that the process exists; it sends nothing.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

/// Removes hidden `.NAME.tmpPID` files left by a killed run (under `dir`, recursively), whose
/// process no longer runs.
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
        if !name.starts_with('.') {
            continue;
        }
        // `.NAME.tmpPID` (the atomic writer) or `.STEM.tmpPID.EXT` (plots).
        if let Some(pos) = name.rfind(".tmp") {
            let digits: String = name[pos + 4..]
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            let rest = &name[pos + 4 + digits.len()..];
            if !rest.is_empty() && !rest.starts_with('.') {
                continue;
            }
            if let Ok(pid) = digits.parse::<i32>() {
                if !alive(pid) || pid as u32 == std::process::id() {
                    let _ = std::fs::remove_file(&p);
                }
            }
        }
    }
}

/// Rows already in `results.csv`, for `--resume`. A torn last line (a run killed while writing
/// it) is cut off the file, with a note; the keys of the complete rows are returned.
pub fn existing_rows(csv: &Path) -> Result<(Vec<Row>, Option<String>)> {
    if !csv.exists() {
        return Ok((Vec::new(), None));
    }
    let bytes = std::fs::read(csv).map_err(|e| Error::io(csv, e))?;
    let mut note = None;
    if !bytes.is_empty() && !bytes.ends_with(b"\n") {
        let keep = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(csv)
            .map_err(|e| Error::io(csv, e))?;
        f.set_len(keep as u64).map_err(|e| Error::io(csv, e))?;
        note = Some(format!(
            "{}: dropped a torn last line ({} bytes) left by an interrupted run",
            csv.display(),
            bytes.len() - keep
        ));
    }
    let meta = std::fs::metadata(csv).map_err(|e| Error::io(csv, e))?;
    if meta.len() == 0 {
        return Ok((Vec::new(), note));
    }
    Ok((crate::rows::read_rows(csv)?, note))
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
