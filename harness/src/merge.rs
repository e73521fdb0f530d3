//! `tetbench merge`: the rows of the shard directories of one sweep, checked and joined into
//! one `results.csv`. Refused, naming the shard, when the shards come from different experiment
//! files, N, tetbench versions or sweeps (their `shard.txt` disagree on the sweep's rows), when
//! a shard is missing, doubled or unfinished, when a shard's rows are not the ones it was given
//! (a row missing, doubled or changed), or when the merged rows are not exactly the sweep's.
//! The output directory is locked as `bench` locks it, is never one of the shards, and results
//! already in it are replaced only with `force`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use algorithms::{Error, Result};

use crate::rows::{read_rows, CsvSink, Row};
use crate::sweep::{keys_hash, row_key, Lock, ShardInfo};

/// Merges `shards` into `out/results.csv` (rows in shard order) and returns the rows. `force`
/// replaces results already in `out`.
pub fn merge(out: &Path, shards: &[PathBuf], force: bool) -> Result<Vec<Row>> {
    refuse_out_among_shards(out, shards)?;
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
        let (Some((_, total)), Some((_, all))) = (&i.rows, &i.keys) else {
            return Err(Error::Input(format!(
                "shard {}: did not finish (continue it with `tetbench bench ... --resume`)",
                d.display()
            )));
        };
        if let (Some((_, t0)), Some((_, a0))) = (&first.rows, &first.keys) {
            if total != t0 {
                return Err(differs(
                    "sweep size (rows_total)",
                    &total.to_string(),
                    &t0.to_string(),
                ));
            }
            if all != a0 {
                return Err(differs(
                    "sweep (the rows of the whole matrix; measured on other data?)",
                    &short(all),
                    &short(a0),
                ));
            }
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
    let (Some((_, total)), Some((_, matrix))) = (first.rows, first.keys.clone()) else {
        return Err(Error::Internal(
            "merge: a finished shard without its rows".into(),
        ));
    };

    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let _lock = Lock::take(out)?;
    let p = out.join("results.csv");
    if !force && std::fs::metadata(&p).is_ok_and(|m| m.len() > 0) {
        return Err(Error::Input(format!(
            "{} already holds results ({}); pass --force to replace them",
            out.display(),
            p.display()
        )));
    }

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
        let mut own = Vec::with_capacity(part.len());
        for r in &part {
            let k = row_key(r);
            if let Some(other) = keys.insert(k.clone(), d) {
                return Err(Error::Input(format!(
                    "shard {}: row {k} is also in {}",
                    d.display(),
                    other.display()
                )));
            }
            own.push(k);
        }
        if i.keys
            .as_ref()
            .is_some_and(|(mine, _)| *mine != keys_hash(&own))
        {
            return Err(Error::Input(format!(
                "shard {}: its rows are not the ones its shard file lists (a row's dataset, variant, projection, size or view was changed, or rows of another run were mixed in)",
                d.display()
            )));
        }
        rows.extend(part);
    }
    if rows.len() != total || keys_hash(keys.keys()) != matrix {
        return Err(Error::Input(format!(
            "the shards hold {} rows, not exactly the sweep's {total}",
            rows.len()
        )));
    }
    let tmp = algorithms::io::files::temp_name(&p, None);
    let written = (|| {
        let mut w = CsvSink::create(&tmp)?;
        for r in &rows {
            w.write(r)?;
        }
        std::fs::rename(&tmp, &p).map_err(|e| Error::io(&p, e))
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written?;
    // Each shard kept the figure images of the cells it measured.
    crate::bench::keep::merge(out, shards)?;
    Ok(rows)
}

/// Refuses an output directory that is one of the shards (the merge would replace that
/// shard's rows with everyone's).
fn refuse_out_among_shards(out: &Path, shards: &[PathBuf]) -> Result<()> {
    let Ok(o) = out.canonicalize() else {
        // Not there yet: no shard can be it.
        return Ok(());
    };
    for d in shards {
        if d.canonicalize().is_ok_and(|c| c == o) {
            return Err(Error::Input(format!(
                "--out {} is the shard {} itself; merge into another directory",
                out.display(),
                d.display()
            )));
        }
    }
    Ok(())
}

fn short(h: &str) -> String {
    format!("{}…", &h[..h.len().min(12)])
}
