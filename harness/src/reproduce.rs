//! `tetbench reproduce`: one loop over the papers' tables ([`crate::papers::TABLES`]), writing
//! each as `DIR/<id>.csv` and `DIR/<id>.md` with its plots (raw rows under `DIR/raw/<id>/`), a
//! status line per table, and the index `DIR/README.md`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use algorithms::render;
use algorithms::{Error, Result};

use crate::papers::{self, Ctx, Done, PaperTable};
use crate::table::{plot_notes, write_table};

/// The status line of one table in `DIR/README.md`; kept in `DIR/raw/<id>/status.md` so that a
/// later `--only` run rewrites the README without losing the tables it did not rerun.
fn status_path(out: &Path, id: &str) -> PathBuf {
    out.join("raw").join(id).join("status.md")
}

fn write_status(out: &Path, id: &str, line: &str) -> Result<()> {
    let p = status_path(out, id);
    if let Some(d) = p.parent() {
        std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
    }
    std::fs::write(&p, line).map_err(|e| Error::io(&p, e))
}

/// The GPU adapter the GPU renderers use, when one of them is registered and an adapter exists.
fn gpu_line() -> Option<String> {
    let gpu_renderers: Vec<&str> = render::REGISTRY
        .iter()
        .filter(|r| r.needs_gpu)
        .map(|r| r.name)
        .collect();
    if gpu_renderers.is_empty() {
        return None;
    }
    Some(match algorithms::gpu::Gpu::shared() {
        Ok(g) => format!(
            "{} ({}; render target {:?}){}",
            algorithms::gpu::describe(&g.info),
            gpu_renderers.join(", "),
            g.target_format,
            if g.info.device_type == algorithms::gpu::wgpu::DeviceType::Cpu {
                " — a software rasteriser: GPU rows measure correctness and relative cost, not GPU speed"
            } else {
                ""
            }
        ),
        Err(e) => format!("none ({e})"),
    })
}

/// The tables `--only` names (all when empty); an unknown id is one line listing the ids.
pub fn select(only: &[String]) -> Result<Vec<&'static dyn PaperTable>> {
    for o in only {
        if papers::find(o).is_none() {
            let ids = papers::ids();
            return Err(Error::Input(format!(
                "--only {o}: no such table (tables: {}){}",
                ids.join(", "),
                algorithms::plugin::did_you_mean(o, &ids)
            )));
        }
    }
    Ok(papers::TABLES
        .iter()
        .copied()
        .filter(|t| only.is_empty() || only.iter().any(|o| o == t.id()))
        .collect())
}

/// Runs one table and writes its files; the status line for the README.
fn run_one(t: &dyn PaperTable, ctx: &Ctx, machine: &str, date: &str) -> Result<String> {
    let t0 = Instant::now();
    let done = t.run(ctx)?;
    let secs = t0.elapsed().as_secs_f64();
    let quick = if ctx.quick { ", --quick" } else { "" };
    Ok(match done {
        Done::Skipped(why) => {
            eprintln!("tetbench: {}: skipped: {why}", t.id());
            format!("skipped: {why} ({date})")
        }
        Done::Files(what) => format!("{what}: {secs:.0} s ({date}{quick})"),
        Done::Table { mut table, plots } => {
            table.id = t.id().to_string();
            table.title = t.title().to_string();
            table
                .notes
                .push(format!("This table took {secs:.0} s to measure."));
            plot_notes(&mut table, &plots);
            write_table(&table, &ctx.out, machine, date)?;
            println!(
                "table: {} ({} rows, {secs:.0} s)",
                ctx.out.join(format!("{}.md", t.id())).display(),
                table.rows.len()
            );
            format!(
                "[{0}.md]({0}.md), [{0}.csv]({0}.csv): {1} rows, {secs:.0} s ({date}{quick})",
                t.id(),
                table.rows.len(),
            )
        }
    })
}

/// Runs every table (or those in `only`), writing tables, plots and `DIR/README.md`.
/// Returns how many measurements failed (each is a row with its message in its table's raw
/// `results.csv`, and shown as failed in the table).
pub fn run(
    quick: bool,
    out: &Path,
    only: &[String],
    sweep: crate::papers::Sweep,
    resume: bool,
) -> Result<usize> {
    let tables = select(only)?;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let ctx = Ctx {
        quick,
        out: out.to_path_buf(),
        sweep,
        resume,
        failed: Default::default(),
    };
    let machine = crate::sysinfo::machine();
    let date = crate::sysinfo::now_utc();
    let started = Instant::now();
    for t in &tables {
        let status = run_one(*t, &ctx, &machine, &date)?;
        write_status(out, t.id(), &status)?;
    }
    let total = started.elapsed().as_secs_f64();
    write_readme(out, quick, only, &machine, &date, total)?;
    println!("wall_time_s: {total:.1}");
    let failed = ctx.failed.get();
    if failed > 0 {
        eprintln!(
            "tetbench: {failed} measurement(s) failed; the tables show them as failed and list their messages"
        );
    }
    Ok(failed)
}

/// The README lists every table: this run's and, after an `--only` run, the earlier ones.
fn write_readme(
    out: &Path,
    quick: bool,
    only: &[String],
    machine: &str,
    date: &str,
    total: f64,
) -> Result<()> {
    let mut readme = format!(
        "# tetbench reproduce{}\n\n- machine: {machine}\n- threads: {}\n",
        if quick { " --quick" } else { "" },
        rayon::current_num_threads(),
    );
    if let Some(g) = gpu_line() {
        let _ = writeln!(readme, "- GPU adapter: {g}");
    }
    let _ = writeln!(
        readme,
        "- last run: {date}{}, {total:.0} s\n- renderers registered: {}\n\nEach table is a `.md` laid out like the paper's table, with the paper's own figures in the `paper …` columns, and a `.csv` of the same rows; the raw measurements (one row per frame and view, every row with its error against the exact reference and its bytes per tet) are in `raw/<table>/results.csv`. Columns marked † depend on the hardware (times and rates); sizes, errors and bytes per tet do not. The papers' GPU timings come from 2006–2010 hardware: compare rates between rows of one run, not with the paper.\n\n| table | what it measures | status |\n| --- | --- | --- |",
        if only.is_empty() {
            String::new()
        } else {
            format!(" (--only {})", only.join(","))
        },
        render::names().join(", ")
    );
    for t in papers::TABLES {
        let status = std::fs::read_to_string(status_path(out, t.id()))
            .map(|s| s.trim().to_string())
            .unwrap_or_else(|_| "not run yet".into());
        // A `|` in a cell (even inside a code span) would split it: escape it.
        let cell = |s: &str| s.replace('|', "\\|");
        let _ = writeln!(
            readme,
            "| {} | **{}.** {} | {} |",
            t.id(),
            cell(t.title()),
            cell(t.about()),
            cell(&status)
        );
    }
    let rp = out.join("README.md");
    std::fs::write(&rp, readme).map_err(|e| Error::io(&rp, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `|` in a table's status line (a file pattern, say) stays inside its README cell.
    #[test]
    fn readme_cells_escape_pipes() {
        let out = std::env::temp_dir().join(format!("tetbench-readme-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        let id = papers::TABLES[0].id();
        write_status(&out, id, "plots `x.png|svg`").unwrap();
        write_readme(&out, true, &[], "m", "d", 1.0).unwrap();
        let readme = std::fs::read_to_string(out.join("README.md")).unwrap();
        let row = readme
            .lines()
            .find(|l| l.starts_with(&format!("| {id} |")))
            .unwrap();
        assert!(row.ends_with("| plots `x.png\\|svg` |"), "{row}");
        // Cells split only at unescaped pipes: id, title and about, status.
        assert_eq!(row.replace("\\|", "").matches('|').count(), 4, "{row}");
        let _ = std::fs::remove_dir_all(&out);
    }
}
