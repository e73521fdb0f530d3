//! `tetbench reproduce`: one loop over the papers' tables ([`crate::papers::TABLES`]), writing
//! each as `DIR/<id>.csv` and `DIR/<id>.md` with its plots (raw rows under `DIR/raw/<id>/`), a
//! status line per table, and the index `DIR/README.md`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use algorithms::render;
use algorithms::{Error, Result};

use crate::papers::{self, Ctx, Done, PaperTable};
use crate::report::html::Section;
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
    algorithms::io::atomic_write(&p, |w| std::io::Write::write_all(w, line.as_bytes()))
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

/// Runs one table and writes its files (the table, its image figure, its report section); the
/// status line for the README.
fn run_one(t: &dyn PaperTable, ctx: &Ctx, machine: &str, date: &str) -> Result<String> {
    let t0 = Instant::now();
    let done = t.run(ctx)?;
    let secs = t0.elapsed().as_secs_f64();
    let quick = if ctx.quick { ", --quick" } else { "" };
    let section = Section {
        id: t.id().to_string(),
        title: t.title().to_string(),
        about: t.about().to_string(),
        ..Default::default()
    };
    // One line per table on stdout, whatever became of it.
    let (status, section) = match done {
        Done::Skipped(why) => {
            println!("{}: skipped: {why}", t.id());
            let status = format!("skipped: {why} ({date})");
            (
                status.clone(),
                Section {
                    status,
                    skipped: true,
                    ..section
                },
            )
        }
        Done::Files(what) => {
            println!("{}: written in {secs:.0} s", t.id());
            let status = format!("{what}: {secs:.0} s ({date}{quick})");
            (
                status.clone(),
                files_section(section, &ctx.out, t.id(), &status)?,
            )
        }
        Done::Table { mut table, plots } => {
            table.id = t.id().to_string();
            table.title = t.title().to_string();
            table
                .notes
                .push(format!("This table took {secs:.0} s to measure."));
            // The image figure of an experiment table, from what its sweep kept under raw/<id>/.
            let raw = ctx.out.join("raw").join(t.id());
            let rows = match raw.join("results.csv") {
                csv if csv.exists() => crate::rows::read_rows(&csv)?,
                _ => Vec::new(),
            };
            let stem = ctx.out.join(format!("{}-images", t.id()));
            let figure = crate::report::figure::draw(&rows, &raw, &stem, t.title())?;
            plot_notes(&mut table, &plots);
            if let Some(f) = &figure {
                table.notes.push(format!("Images: ![{0}]({0})", f.png));
            }
            write_table(&table, &ctx.out, machine, date)?;
            println!(
                "{}: {} rows in {secs:.0} s: {}",
                t.id(),
                table.rows.len(),
                ctx.out.join(format!("{}.md", t.id())).display(),
            );
            let status = format!(
                "[{0}.md]({0}.md), [{0}.csv]({0}.csv): {1} rows, {secs:.0} s ({date}{quick})",
                t.id(),
                table.rows.len(),
            );
            let section = Section {
                status: format!("{} rows, {secs:.0} s ({date}{quick})", table.rows.len()),
                figure,
                files: vec![format!("{}.md", t.id()), format!("{}.csv", t.id())],
                ..section
            }
            .with_table(&table)
            .with_plots(&plots, &ctx.out)
            .with_failures(&rows);
            (status, section)
        }
    };
    section.save(&section_path(&ctx.out, t.id()))?;
    Ok(status)
}

/// A table that wrote its own files: its CSV as the section's table, its PNG plots
/// (`DIR/<id>-*.png`, `DIR/<id>_*.png`).
fn files_section(section: Section, out: &Path, id: &str, status: &str) -> Result<Section> {
    let csv = out.join(format!("{id}.csv"));
    let mut table = crate::table::Table::default();
    if csv.exists() {
        let err = |e: csv::Error| Error::Input(format!("{}: {e}", csv.display()));
        let f = algorithms::io::open_input(&csv)?;
        let mut r = csv::Reader::from_reader(algorithms::io::files::BoundedLines::new(
            f,
            crate::rows::MAX_CSV_LINE,
        ));
        for h in r.headers().map_err(err)? {
            table.col(h, false);
        }
        for rec in r.records() {
            table
                .rows
                .push(rec.map_err(err)?.iter().map(String::from).collect());
        }
    }
    let mut plots: Vec<PathBuf> = std::fs::read_dir(out)
        .map_err(|e| Error::io(out, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let n = p.file_name().unwrap_or_default().to_string_lossy();
            (n.starts_with(&format!("{id}-")) || n.starts_with(&format!("{id}_")))
                && n.ends_with(".png")
        })
        .collect();
    plots.sort();
    let files = [format!("{id}.md"), format!("{id}.csv")]
        .into_iter()
        .filter(|f| out.join(f).exists())
        .collect();
    Ok(Section {
        status: status.to_string(),
        files,
        ..section
    }
    .with_table(&table)
    .with_plots(&plots, out))
}

/// Where a table's report section is kept (a later `--only` run rebuilds the whole report).
fn section_path(out: &Path, id: &str) -> PathBuf {
    out.join("raw").join(id).join("section.json")
}

/// `DIR/index.html`: every table's section, this run's and the earlier ones.
fn write_index(out: &Path, quick: bool, only: &[String], total: f64) -> Result<PathBuf> {
    let mut facts = crate::report::facts();
    if let Some(g) = gpu_line() {
        facts.push(("GPU adapter".into(), g));
    }
    facts.push(("renderers registered".into(), render::names().join(", ")));
    facts.push((
        "this run".into(),
        format!(
            "{}{total:.0} s",
            if only.is_empty() {
                String::new()
            } else {
                format!("--only {}, ", only.join(","))
            }
        ),
    ));
    let sections = papers::TABLES
        .iter()
        .map(|t| {
            Section::load(&section_path(out, t.id())).unwrap_or_else(|| Section {
                id: t.id().to_string(),
                title: t.title().to_string(),
                about: t.about().to_string(),
                status: "not run yet".into(),
                ..Default::default()
            })
        })
        .collect();
    let report = crate::report::html::Report {
        title: format!("tetbench reproduce{}", if quick { " --quick" } else { "" }),
        facts,
        sections,
    };
    crate::report::html::write(&report, out)
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
    // A shard holds raw rows only: the report comes with the merge.
    if !matches!(ctx.sweep, crate::papers::Sweep::Shard(_)) {
        println!(
            "report: {}",
            write_index(out, quick, only, total)?.display()
        );
    }
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
        let status = algorithms::io::read_input_string(&status_path(out, t.id()), 1 << 16)
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
    algorithms::io::atomic_write(&rp, |w| std::io::Write::write_all(w, readme.as_bytes()))
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
