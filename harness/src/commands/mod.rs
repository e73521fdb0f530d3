//! The subcommands: each reads its inputs, calls the library, prints `name: value` lines (or JSON).

use algorithms::image::Image;
use algorithms::render::{self};
use algorithms::{metrics, Error, Result};

mod list;
mod mesh;
mod output;

use list::list;
use mesh::{convert, info, render_cmd};
use output::{num, print_pairs};

use crate::bench;
use crate::cli::{Cli, Command, PeerCheckArgs, PeerCommand};
use crate::meshes::parse_size;
use crate::rows;

/// How a command that finished ended: cleanly, or with measurements that failed (rows with NaN
/// times and their message; the run went on without them). `main` maps it to the exit status.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Finished {
    Clean,
    /// This many rows failed.
    FailedRows(usize),
}

impl Finished {
    /// `FailedRows` when any of `n` rows failed.
    pub fn with_failed(n: usize) -> Finished {
        if n == 0 {
            Finished::Clean
        } else {
            Finished::FailedRows(n)
        }
    }

    /// The process exit status: 0, or 3 when rows failed.
    pub fn exit_code(self) -> u8 {
        match self {
            Finished::Clean => 0,
            Finished::FailedRows(_) => 3,
        }
    }
}

/// How `tetbench bench` runs, from its flags.
pub struct BenchFlags<'a> {
    pub config: &'a std::path::Path,
    pub out: &'a std::path::Path,
    pub plots: bool,
    pub shard: Option<&'a str>,
    pub resume: bool,
    pub force: bool,
}

/// `tetbench bench`: validate everything first, then run, then plot.
fn bench_cmd(f: &BenchFlags) -> Result<Finished> {
    let shard = match f.shard {
        Some(s) => crate::sweep::Shard::parse(s)?,
        None => crate::sweep::Shard::ALL,
    };
    let exp = crate::experiment::load(f.config)?;
    let out = f.out;
    let mut opts = bench::RunOptions::new(&exp, out);
    opts.shard = shard;
    opts.resume = f.resume;
    opts.force = f.force;
    opts.identity = crate::sweep::experiment_hash(f.config)?;
    let o = bench::run(&exp, &opts)?;
    let csv = out.join("results.csv");
    if o.interrupted {
        return Err(Error::Input(format!(
            "interrupted: {} finished rows kept in {} (continue with --resume)",
            o.rows.len(),
            csv.display()
        )));
    }
    println!("rows: {}", o.rows.len());
    println!("results: {}", csv.display());
    if !o.pairs.is_empty() {
        println!("pairs: {}", out.join("pairs.csv").display());
    }
    println!(
        "reference_images: {} rendered, {} from cache",
        o.reference_renders, o.reference_hits
    );
    // A shard's plots, figure and report would show a part of the sweep: `merge` draws them.
    if shard.count == 1 {
        let plots = if f.plots {
            crate::plots::all(&o.rows, &o.pairs, out)?
        } else {
            Vec::new()
        };
        for p in &plots {
            println!("plot: {}", p.display());
        }
        let command = format!("tetbench bench {}", f.config.display());
        for p in crate::report::sweep(out, &o.rows, &plots, &command)? {
            println!("report: {}", p.display());
        }
    }
    Ok(report_failed(&o.rows))
}

/// Says how many rows failed or lack their error, and how the command ends.
fn report_failed(rows: &[rows::Row]) -> Finished {
    let mut bad = 0;
    for (test, what) in [
        (crate::sweep::failed as fn(&rows::Row) -> bool, "failed"),
        (crate::sweep::error_missing, "have no error measurement"),
    ] {
        let hit: Vec<&rows::Row> = rows.iter().filter(|r| test(r)).collect();
        if let Some(first) = hit.first() {
            eprintln!(
                "tetbench: {} of {} rows {what} (their note column says why; first: {} {}: {})",
                hit.len(),
                rows.len(),
                first.dataset,
                first.variant,
                first.note
            );
        }
        bad += hit.len();
    }
    Finished::with_failed(bad)
}

/// `tetbench merge`: check and merge shard directories, then plot.
fn merge_cmd(
    out: &std::path::Path,
    shards: &[std::path::PathBuf],
    plots: bool,
    force: bool,
) -> Result<Finished> {
    let rows = crate::merge::merge(out, shards, force)?;
    println!("rows: {}", rows.len());
    println!("results: {}", out.join("results.csv").display());
    let plots = if plots {
        crate::plots::all(&rows, &[], out)?
    } else {
        Vec::new()
    };
    for p in &plots {
        println!("plot: {}", p.display());
    }
    for p in crate::report::sweep(out, &rows, &plots, "tetbench merge")? {
        println!("report: {}", p.display());
    }
    Ok(report_failed(&rows))
}

/// Runs one subcommand. `Err` is a run that stopped (bad input, an I/O error, Ctrl-C); a run
/// that finished says whether some of its measurements failed.
pub fn run(cli: Cli) -> Result<Finished> {
    // Peers join the registry here, once, before any renderer is looked up.
    match &cli.command {
        Command::List(a) => crate::peers::register(&a.peers.files, None, false)?,
        Command::Render(a) => crate::peers::register(&a.peers.files, None, false)?,
        Command::Bench {
            config,
            peers,
            allow_peers,
            ..
        } => crate::peers::register(&peers.files, Some(config), *allow_peers)?,
        Command::Reproduce { peers, .. } => crate::peers::register(&peers.files, None, false)?,
        Command::Peer {
            command: PeerCommand::Check(a),
        } => crate::peers::register(&a.peers.files, None, false)?,
        _ => {}
    }
    let done = |r: Result<()>| r.map(|()| Finished::Clean);
    match cli.command {
        Command::Info { mesh, json } => done(info(&mesh, json)),
        Command::Convert { mesh, out } => done(convert(&mesh, &out)),
        Command::Render(args) => done(render_cmd(&args)),
        Command::Peer {
            command: PeerCommand::Check(args),
        } => peer_check(&args),
        Command::Compare {
            test,
            reference,
            json,
        } => {
            let ext = |p: &std::path::Path| {
                p.extension()
                    .map(|e| e.to_string_lossy().to_ascii_lowercase())
                    .unwrap_or_default()
            };
            if ext(&test) != ext(&reference) {
                eprintln!(
                    "tetbench: warning: comparing {} with {}: a PNG holds 8-bit values \
                     (floor(255 v + 0.5), no gamma) and an EXR the renderer's f32 values \
                     (docs/contract.md), so the error includes the PNG's quantisation; \
                     compare EXR with EXR for the renderer's own error",
                    test.display(),
                    reference.display()
                );
            }
            let a = Image::read(&test)?;
            let b = Image::read(&reference)?;
            for (img, p) in [(&a, &test), (&b, &reference)] {
                let n = img.non_finite_pixels();
                if n > 0 {
                    eprintln!(
                        "tetbench: warning: {}: {n} pixels are NaN or infinite; the error is not finite",
                        p.display()
                    );
                }
            }
            let e = metrics::compare(&a, &b).map_err(|e| {
                Error::Input(format!(
                    "{} vs {}: {e}",
                    test.display(),
                    reference.display()
                ))
            })?;
            print_pairs(e.fields().iter().map(|(k, v)| (*k, num(*v))), json);
            Ok(Finished::Clean)
        }
        Command::List(_) => {
            list();
            Ok(Finished::Clean)
        }
        Command::Bench {
            config,
            out,
            no_plots,
            shard,
            resume,
            force,
            ..
        } => bench_cmd(&BenchFlags {
            config: &config,
            out: &out,
            plots: !no_plots,
            shard: shard.as_deref(),
            resume,
            force,
        }),
        Command::Merge {
            out,
            shards,
            no_plots,
            force,
        } => merge_cmd(&out, &shards, !no_plots, force),
        Command::Reproduce {
            quick,
            out,
            only,
            shard,
            merge,
            resume,
            slurm,
            ..
        } => {
            if let Some(n) = slurm {
                return done(slurm_commands(quick, &out, &only, n));
            }
            let sweep = match (shard, merge.is_empty()) {
                (Some(s), _) => crate::papers::Sweep::Shard(crate::sweep::Shard::parse(&s)?),
                (None, false) => crate::papers::Sweep::Merge(merge),
                (None, true) => crate::papers::Sweep::Whole,
            };
            let failed = crate::reproduce::run(quick, &out, &only, sweep, resume)?;
            Ok(Finished::with_failed(failed))
        }
        Command::Plot { dir } if dir.join("raw").is_dir() => {
            // A `reproduce` directory: every table's plots from its raw rows.
            for p in crate::papers::replot_all(&dir)? {
                println!("plot: {}", p.display());
            }
            Ok(Finished::Clean)
        }
        Command::Plot { dir } => {
            let csv = dir.join("results.csv");
            let rows = rows::read_rows(&csv)?;
            if rows.is_empty() {
                return Err(Error::Input(format!(
                    "{}: no rows, nothing to plot",
                    csv.display()
                )));
            }
            let pairs = rows::read_pairs(&dir.join("pairs.csv"))?;
            for p in crate::plots::all(&rows, &pairs, &dir)? {
                println!("plot: {}", p.display());
            }
            Ok(Finished::Clean)
        }
    }
}

/// `tetbench peer check NAME` or `tetbench peer check -- CMD ARGS…`.
fn peer_check(args: &PeerCheckArgs) -> Result<Finished> {
    use algorithms::render::peer::{Launch, PeerFamily, PeerSpec};
    let size = parse_size(&args.size).map_err(|e| match e {
        Error::Input(m) => Error::Input(format!("--{m}")),
        o => o,
    })?;
    let family = match &args.family {
        None => None,
        Some(f) => Some(PeerFamily::parse(f).ok_or_else(|| {
            Error::Input(format!("--family {f}: expected pt, raycasting or other"))
        })?),
    };
    let spec = match (&args.name, args.command.split_first()) {
        (Some(name), _) => match render::peer::spec_of(name) {
            Some(spec) => spec?,
            None => {
                render::info(name)?;
                return Err(Error::Input(format!(
                    "'{name}' is a renderer built into tetbench, not a peer"
                )));
            }
        },
        (None, Some((program, rest))) => {
            // Until its hello says otherwise (check::run).
            let family = PeerFamily::Other;
            if !(args.timeout.is_finite() && args.timeout > 0.0 && args.timeout <= 86_400.0) {
                return Err(Error::Input(format!(
                    "--timeout {}: expected seconds in (0, 86400]",
                    args.timeout
                )));
            }
            PeerSpec {
                name: std::path::Path::new(program)
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_else(|| program.clone()),
                description: String::new(),
                family,
                integrators: Vec::new(),
                params: Vec::new(),
                timeout: std::time::Duration::from_secs_f64(args.timeout),
                launch: Launch {
                    program: program.into(),
                    args: rest.iter().map(Into::into).collect(),
                    cwd: Some(
                        std::env::current_dir()
                            .map_err(|e| Error::Io(format!("the current directory: {e}")))?,
                    ),
                    env: Vec::new(),
                    files: Vec::new(),
                },
                origin: "the command line".into(),
            }
        }
        (None, None) => {
            return Err(Error::Input(
                "peer check: name a peer, or give its command after --".into(),
            ))
        }
    };
    let failed = crate::peers::check::check(spec, family, size, args.out.as_deref())?;
    Ok(Finished::with_failed(failed))
}

/// `reproduce --slurm N`: the sbatch commands of an N-task array and its merge job.
fn slurm_commands(quick: bool, out: &std::path::Path, only: &[String], n: usize) -> Result<()> {
    if n == 0 || n > 100_000 {
        return Err(Error::Input(format!(
            "--slurm {n}: the number of shards must be 1..100000"
        )));
    }
    let exe = std::env::current_exe()
        .map(|p| p.display().to_string())
        .unwrap_or_else(|_| "tetbench".into());
    let mut flags = String::new();
    if quick {
        flags.push_str(" --quick");
    }
    if !only.is_empty() {
        flags.push_str(&format!(" --only {}", only.join(",")));
    }
    let o = out.display();
    let shards: Vec<String> = (0..n).map(|i| format!("{o}/shard-{i}")).collect();
    println!("# {n}-task array, then the merge once every task succeeded (a shard whose only trouble is failed rows, exit 3, counts as succeeded: the merge shows them). Add -p <partition> --gres=gpu:1 for the GPU tables.");
    println!(
        "array=$(sbatch --parsable --array=0-{} --cpus-per-task=2 --wrap 'export RAYON_NUM_THREADS=$SLURM_CPUS_PER_TASK; {exe} reproduce{flags} --out {o}/shard-$SLURM_ARRAY_TASK_ID --shard $SLURM_ARRAY_TASK_ID/{n}; rc=$?; [ $rc -eq 3 ] && rc=0; exit $rc')",
        n - 1
    );
    println!(
        "sbatch --dependency=afterok:$array --wrap '{exe} reproduce{flags} --out {o} --merge {}; rc=$?; [ $rc -eq 3 ] && rc=0; exit $rc'",
        shards.join(" ")
    );
    Ok(())
}
