//! `datasets-gen --list`; `datasets-gen NAME[:N] [--tets N] [--seed S] --out FILE`
//! (CONVENTIONS §8).
//!
//! The mesh is generated once and the writer streams from it into the file, so writing holds
//! no second copy (a 278M-tet mesh is written in the memory the mesh takes).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Parser;

/// Generates synthetic tetrahedral meshes: lattices, paper-sized analogues, hard cases.
#[derive(Parser, Debug)]
#[command(name = "datasets-gen", version, about)]
struct Args {
    /// Print every generator: name, default size, description, what hard cases break.
    #[arg(long)]
    list: bool,
    /// Generator name (see --list), optionally with its size as `NAME:N` (as tetbench takes it).
    #[arg(required_unless_present = "list")]
    name: Option<String>,
    /// Number of tets (default: the generator's size).
    #[arg(long)]
    tets: Option<usize>,
    /// Random seed (jitter, Gaussian centres); the same default as tetbench's.
    #[arg(long, default_value_t = datasets_gen::DEFAULT_SEED)]
    seed: u64,
    /// Output file (.off, .vtu or .vtk). A time-varying mesh written to .off gives one file per
    /// step, FILE with `.NNNN` before the extension.
    #[arg(long, required_unless_present = "list")]
    out: Option<PathBuf>,
}

fn fail(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("datasets-gen: {msg}");
    ExitCode::from(2)
}

fn step_path(out: &Path, k: usize) -> PathBuf {
    let stem = out.file_stem().unwrap_or_default().to_string_lossy();
    let ext = out.extension().unwrap_or_default().to_string_lossy();
    out.with_file_name(format!("{stem}.{k:04}.{ext}"))
}

fn main() -> ExitCode {
    // `tetbench list | head` must end quietly, not panic on a closed pipe: restore the default
    // SIGPIPE action (Rust ignores it, turning a closed pipe into a failing print).
    #[cfg(unix)]
    // SAFETY: called before any thread starts; SIG_DFL is a valid action for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                print!("{e}");
                return ExitCode::SUCCESS;
            }
            // clap's message up to its usage section, as one line.
            let text = e.to_string();
            let line = text
                .lines()
                .take_while(|l| !l.starts_with("Usage:"))
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect::<Vec<_>>()
                .join(" ");
            let line = line.trim_start_matches("error: ");
            return fail(format!("{line} (see --help)"));
        }
    };
    if args.list {
        for g in datasets_gen::generators() {
            match g.breaks {
                Some(b) => println!(
                    "{:<18} {:>9}  {} [breaks: {b}]",
                    g.name, g.default_tets, g.description
                ),
                None => println!("{:<18} {:>9}  {}", g.name, g.default_tets, g.description),
            }
        }
        return ExitCode::SUCCESS;
    }
    let (Some(name), Some(out)) = (args.name, args.out) else {
        return fail("NAME and --out FILE are required (see --help)");
    };
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if !algorithms::io::writers::FORMATS.contains(&ext.as_str()) {
        return fail(format!(
            "{}: cannot write '.{ext}' (known: .{})",
            out.display(),
            algorithms::io::writers::FORMATS.join(", .")
        ));
    }
    let (name, tets) = match datasets_gen::parse_spec(&name) {
        Ok((n, t)) => (n.to_string(), t),
        Err(e) => return fail(e),
    };
    let tets = match (tets, args.tets) {
        (Some(a), Some(b)) if a != b => {
            return fail(format!(
                "{name}: two sizes, {a} (NAME:N) and {b} (--tets); give one"
            ))
        }
        (a, b) => a.or(b),
    };
    let mut mesh = match datasets_gen::generate(&name, tets, args.seed) {
        Ok(m) => m,
        Err(e) => return fail(e),
    };
    let (field, steps) = {
        let f = &mesh.fields()[0];
        (f.name.clone(), f.steps.len())
    };
    if ext == "off" && steps > 1 {
        // .off holds one scalar per vertex: one file per step; none left behind on failure.
        let mut written = Vec::new();
        for k in 0..steps {
            let path = step_path(&out, k);
            let r = mesh
                .select_field(&field, k)
                .and_then(|_| algorithms::io::write(&mesh, &path));
            if let Err(e) = r {
                for p in &written {
                    std::fs::remove_file(p).ok();
                }
                return fail(e);
            }
            written.push(path);
        }
        println!(
            "{name}: {} tets, {} vertices, {steps} steps -> {} .. {}",
            mesh.num_tets(),
            mesh.num_vertices(),
            written[0].display(),
            written[steps - 1].display()
        );
        return ExitCode::SUCCESS;
    }
    if let Err(e) = algorithms::io::write(&mesh, &out) {
        return fail(e);
    }
    println!(
        "{name}: {} tets, {} vertices -> {}",
        mesh.num_tets(),
        mesh.num_vertices(),
        out.display()
    );
    ExitCode::SUCCESS
}
