//! `tetbench merge`: the rows of the shard directories of one sweep, checked and joined into
//! one `results.csv`. Refused, naming the shard, when the shards come from different experiment
//! files, N or tetbench versions, when a shard is missing, doubled or unfinished, or when a row
//! is missing or doubled.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use algorithms::{Error, Result};

use crate::rows::{read_rows, CsvSink, Row};
use crate::sweep::{row_key, ShardInfo};

/// Merges `shards` into `out/results.csv` (rows in shard order) and returns the rows.
pub fn merge(out: &Path, shards: &[PathBuf]) -> Result<Vec<Row>> {
    let mut infos: Vec<(ShardInfo, &PathBuf)> = Vec::new();
    for d in shards {
        let info = ShardInfo::read(d)?.ok_or_else(|| {
            Error::Input(format!(
                "shard {}: no {} (not a `tetbench bench --shard` output directory)",
                d.display(),
                crate::sweep::SHARD_FILE
            ))
        })?;
        infos.push((info, d));
    }
    let (first, first_dir) = &infos[0];
    let mut seen: BTreeMap<usize, &PathBuf> = BTreeMap::new();
    for (i, d) in &infos {
        let differs = |what: &str, a: &str, b: &str| {
            Error::Input(format!(
                "shard {}: {what} {a} differs from {}'s {b}",
                d.display(),
                first_dir.display()
            ))
        };
        if i.experiment != first.experiment {
            return Err(differs(
                "experiment file",
                &short(&i.experiment),
                &short(&first.experiment),
            ));
        }
        if i.shard.count != first.shard.count {
            return Err(differs(
                "shard count N =",
                &i.shard.count.to_string(),
                &first.shard.count.to_string(),
            ));
        }
        if i.version != first.version {
            return Err(differs("tetbench version", &i.version, &first.version));
        }
        if i.rows.is_none() {
            return Err(Error::Input(format!(
                "shard {}: did not finish (continue it with `tetbench bench ... --resume`)",
                d.display()
            )));
        }
        if let Some(other) = seen.insert(i.shard.index, d) {
            return Err(Error::Input(format!(
                "shard {}: shard {} is given twice (also {})",
                d.display(),
                i.shard,
                other.display()
            )));
        }
    }
    let n = first.shard.count;
    if let Some(missing) = (0..n).find(|i| !seen.contains_key(i)) {
        return Err(Error::Input(format!(
            "shard {missing}/{n} is missing (given: {})",
            seen.keys()
                .map(|i| format!("{i}/{n}"))
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let total = first.rows.map_or(0, |r| r.1);
    let mut rows = Vec::new();
    let mut keys: BTreeMap<String, &PathBuf> = BTreeMap::new();
    for (i, d) in &infos {
        let csv = d.join("results.csv");
        let part = read_rows(&csv)?;
        let want = i.rows.map_or(0, |r| r.0);
        if part.len() != want {
            return Err(Error::Input(format!(
                "shard {}: {} rows in results.csv, its shard file says {want}",
                d.display(),
                part.len()
            )));
        }
        for r in &part {
            if let Some(other) = keys.insert(row_key(r), d) {
                return Err(Error::Input(format!(
                    "shard {}: row {} is also in {}",
                    d.display(),
                    row_key(r),
                    other.display()
                )));
            }
        }
        rows.extend(part);
    }
    if rows.len() != total {
        return Err(Error::Input(format!(
            "the shards hold {} rows, the sweep has {total}",
            rows.len()
        )));
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let p = out.join("results.csv");
    let tmp = out.join(format!(".results.csv.tmp{}", std::process::id()));
    {
        let mut w = CsvSink::create(&tmp)?;
        for r in &rows {
            w.write(r)?;
        }
    }
    std::fs::rename(&tmp, &p).map_err(|e| Error::io(&p, e))?;
    // Each shard kept the figure images of the cells it measured.
    crate::bench::keep::merge(out, shards)?;
    Ok(rows)
}

fn short(h: &str) -> String {
    format!("{}…", &h[..h.len().min(12)])
}
