//! The subcommands: each reads its inputs, calls the library, prints `name: value` lines (or JSON).

use std::time::Instant;

use algorithms::camera::{Camera, Projection, View};
use algorithms::image::Image;
use algorithms::io;
use algorithms::render::{self, RenderOptions};
use algorithms::{metrics, optics, tf, util::alloc, Error, Result, TransferFunction};
use serde_json::{json, Map, Value};

use crate::bench;
use crate::cli::{Cli, Command, MeshArgs, PeerCheckArgs, PeerCommand, RenderArgs};
use crate::measure::{measure, Frames};
use crate::meshes::{load_mesh, parse_size};
use crate::rows;
use crate::table;

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

/// Prints `name: value` lines, or one JSON object.
fn print_pairs<'a>(pairs: impl IntoIterator<Item = (&'a str, Value)>, as_json: bool) {
    let pairs: Vec<(&str, Value)> = pairs.into_iter().collect();
    if as_json {
        let mut m = Map::new();
        for (k, v) in pairs {
            m.insert(k.to_string(), v);
        }
        println!("{}", Value::Object(m));
    } else {
        for (k, v) in pairs {
            match v {
                Value::String(s) => println!("{k}: {s}"),
                Value::Number(n) => match (n.as_u64(), n.as_i64(), n.as_f64()) {
                    (Some(u), _, _) => println!("{k}: {u}"),
                    (_, Some(i), _) => println!("{k}: {i}"),
                    (_, _, Some(f)) => println!("{k}: {}", table::plain(f)),
                    _ => println!("{k}: {n}"),
                },
                // serde_json turns inf and NaN into null (numbers go through `num`, which
                // keeps them as "inf" and "NaN").
                Value::Null => println!("{k}: null"),
                other => println!("{k}: {other}"),
            }
        }
    }
}

/// A float for output: inf and NaN become the strings "inf", "-inf" and "NaN" rather than
/// JSON's null.
fn num(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        json!(v.to_string())
    }
}

/// `tetbench convert`: the mesh as tetbench loads it, written by extension.
fn convert(args: &MeshArgs, out: &std::path::Path) -> Result<()> {
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if !io::writers::FORMATS.contains(&ext.as_str()) {
        return Err(Error::Input(format!(
            "{}: output must end in .{}",
            out.display(),
            io::writers::FORMATS.join(", .")
        )));
    }
    let mesh = load_mesh(&args.to_spec())?;
    io::write(&mesh, out)?;
    let (field, step) = mesh.active_field();
    let arrays: usize = mesh.fields().iter().map(|f| f.steps.len()).sum();
    if ext == "off" && arrays > 1 {
        eprintln!(
            "tetbench: note: .off holds one field: {field}[{step}] written, the other {} arrays are not (write .vtu or .vtk for every field)",
            arrays - 1
        );
    }
    print_pairs(
        [
            ("vertices", json!(mesh.num_vertices())),
            ("tets", json!(mesh.num_tets())),
            ("scalar_field", json!(format!("{field}[{step}]"))),
            ("arrays", json!(if ext == "off" { 1 } else { arrays })),
            ("out", json!(out.display().to_string())),
        ],
        false,
    );
    Ok(())
}

fn info(args: &MeshArgs, as_json: bool) -> Result<()> {
    let t0 = Instant::now();
    let mesh = load_mesh(&args.to_spec())?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let bb = mesh.bbox();
    let (lo, hi) = mesh.scalar_range();
    let (field, step) = mesh.active_field();
    let fields: Vec<String> = mesh
        .fields()
        .iter()
        .map(|f| {
            if f.steps.len() > 1 {
                format!("{}[{} steps]", f.name, f.steps.len())
            } else {
                f.name.clone()
            }
        })
        .collect();
    let adj = mesh.adjacency();
    let pairs = vec![
        ("vertices", json!(mesh.num_vertices())),
        ("tets", json!(mesh.num_tets())),
        (
            "scalar_range",
            if as_json {
                json!([lo, hi])
            } else {
                json!(format!("[{lo}, {hi}]"))
            },
        ),
        (
            "bbox",
            if as_json {
                json!([bb.min.to_array(), bb.max.to_array()])
            } else {
                json!(format!(
                    "[{}, {}, {}] [{}, {}, {}]",
                    bb.min.x, bb.min.y, bb.min.z, bb.max.x, bb.max.y, bb.max.z
                ))
            },
        ),
        ("degenerate_tets", json!(mesh.degenerate_tets())),
        ("boundary_faces", json!(mesh.boundary_faces().len())),
        ("convex", json!(mesh.is_convex())),
        ("diagonal", json!(mesh.diagonal())),
        ("negative_tets", json!(mesh.negative_tets())),
        ("nonmanifold_faces", json!(adj.nonmanifold_faces)),
        ("scalar_field", json!(format!("{field}[{step}]"))),
        ("fields", json!(fields.join(", "))),
        ("load_ms", json!((load_ms * 1000.0).round() / 1000.0)),
    ];
    if as_json {
        print_pairs(pairs, true);
    } else {
        print_pairs(pairs, false);
    }
    Ok(())
}

fn render_cmd(args: &RenderArgs) -> Result<()> {
    // Check every name and flag before the (possibly long) load and render.
    let ext = args
        .out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("exr" | "png")) {
        return Err(Error::Input(format!(
            "{}: output must end in .exr or .png",
            args.out.display()
        )));
    }
    let params = args
        .params
        .iter()
        .map(|kv| {
            kv.split_once('=')
                .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
                .ok_or_else(|| {
                    algorithms::Error::Input(format!("--param {kv}: expected KEY=VALUE"))
                })
        })
        .collect::<Result<Vec<_>>>()?;
    let opts = RenderOptions {
        sort: args.sort.clone(),
        integrator: args.integrator.clone(),
        params,
        log_dir: None,
    };
    let mut renderer = render::make(&args.renderer, &opts)?;
    crate::bench::announce_peers([args.renderer.as_str()]);
    let tf = TransferFunction::load(&args.tf)?;
    let view = View::parse(&args.view)?;
    let projection = Projection::parse(&args.projection)?;
    let (w, h) = parse_size(&args.size).map_err(|e| match e {
        Error::Input(m) => Error::Input(format!("--{m}")),
        o => o,
    })?;
    let mesh = load_mesh(&args.mesh.to_spec())?;

    let t0 = Instant::now();
    let (res, bytes, _peak) =
        crate::measure::prepare_counted(&args.renderer, || renderer.prepare(&mesh, &tf));
    res?;
    let setup_ms = t0.elapsed().as_secs_f64() * 1e3;
    let camera = Camera::new(&mesh.bbox(), view, projection, w, h);
    let once = Frames {
        warmup: 0,
        repeats: 1,
    };
    let frame = measure(renderer.as_mut(), &mesh, &camera, once)?;
    frame.image.write(&args.out)?;

    let t = frame.times;
    let tets = mesh.num_tets() as f64;
    let (d, memory) = (renderer.describe(), renderer.memory());
    let mut pairs = vec![
        ("renderer", json!(d.name)),
        ("sort", json!(d.sort)),
        ("integrator", json!(d.integrator)),
        ("device", json!(d.device)),
        ("tets", json!(mesh.num_tets())),
        ("width", json!(w)),
        ("height", json!(h)),
        ("setup_ms", num(setup_ms)),
        ("project_ms", num(t.project_ms)),
        ("sort_ms", num(t.sort_ms)),
        ("draw_ms", num(t.draw_ms)),
        ("readback_ms", num(t.readback_ms)),
        ("total_ms", num(t.total_ms)),
        ("tets_per_s", num(tets / (t.total_ms.max(1e-9) * 1e-3))),
        (
            "cpu_bytes_per_tet",
            // An external renderer (VTK): its helper process's peak RSS.
            if let Some(b) = memory.external_bytes {
                num(b as f64 / tets)
            } else if alloc::is_counting() {
                num(bytes as f64 / tets)
            } else {
                json!("not measured")
            },
        ),
        ("gpu_bytes_per_tet", num(memory.gpu_bytes as f64 / tets)),
        // The fixed cost kept apart from cpu_bytes_per_tet (CONVENTIONS §7).
        (
            "shared_fixed_bytes",
            json!(crate::measure::shared_fixed_bytes()),
        ),
        ("non_finite_pixels", json!(frame.image.non_finite_pixels())),
    ];
    for (k, v) in &frame.counters {
        pairs.push((k, num(*v)));
    }
    pairs.push(("out", json!(args.out.display().to_string())));
    print_pairs(pairs, args.json);
    Ok(())
}

fn list() {
    println!("renderers:");
    for r in render::all() {
        println!(
            "  {:<12} {} [{}{}]",
            r.name,
            r.description,
            match render::peer_family(r) {
                Some(f) => format!("{}, peer of family {}", r.family.name(), f.name()),
                None => r.family.name().to_string(),
            },
            if r.needs_gpu { ", GPU" } else { "" }
        );
        // Peers say what they run, or (VTK's) how to enable them.
        match render::peer::find(r.name) {
            Some(p) => println!(
                "  {:<12}   runs: {} (declared in {})",
                "",
                p.spec.launch.command_line(),
                p.spec.origin
            ),
            None if r.family == render::Family::External => match render::vtk::python() {
                Ok(p) => println!(
                    "  {:<12}   enabled: {}={}",
                    "",
                    render::vtk::PYTHON_VAR,
                    p.display()
                ),
                Err(e) => println!("  {:<12}   {e}", ""),
            },
            None => {}
        }
        if !r.sorts.is_empty() {
            println!(
                "  {:<12}   sorts: {} (default {})",
                "",
                r.sorts.join(", "),
                r.default_sort
            );
        }
        if render::is_wrapper(r.name) {
            println!("  {:<12}   integrators: {}", "", r.integrators.join(", "));
        } else {
            println!(
                "  {:<12}   integrators: {} (default {})",
                "",
                r.integrators.join(", "),
                r.default_integrator
            );
        }
        for p in r.params {
            let default = if p.default.is_empty() {
                String::new()
            } else {
                format!(" (default {})", p.default)
            };
            println!("  {:<12}   param {}: {}{default}", "", p.name, p.doc);
        }
    }
    println!("sorts:");
    for s in algorithms::sort::REGISTRY {
        let arg = s
            .params
            .first()
            .map(|p| format!(":{}", p.name))
            .unwrap_or_default();
        println!("  {:<20} {}", format!("{}{arg}", s.name), s.description);
        for p in s.params {
            println!(
                "  {:<20}   {}: {} (default {})",
                "", p.name, p.doc, p.default
            );
        }
    }
    println!("integrators:");
    for i in optics::REGISTRY {
        println!(
            "  {:<12} {}{}",
            i.name,
            i.description,
            if i.on_gpu { "" } else { " [CPU only]" }
        );
    }
    println!("transfer functions (presets): {}", tf::PRESETS.join(", "));
    // What the GPU renderers would run on (TETBENCH_ADAPTER=<index or name part> picks one).
    let adapters = algorithms::gpu::adapters();
    if adapters.is_empty() {
        println!("gpu adapters: none (the GPU renderers will refuse to run)");
    } else {
        println!("gpu adapters (TETBENCH_ADAPTER=<index or part of the name>):");
        for (i, a) in adapters.iter().enumerate() {
            println!("  {i}: {}", algorithms::gpu::describe(a));
        }
    }
    println!("datasets (NASA grids, from $TETBENCH_DATA or ../shared/datasets):");
    for (n, f, s) in io::SHORT_NAMES {
        println!("  {n:<12} {f} ({s})");
    }
    println!("datasets (datasets-gen, NAME or NAME:TETS):");
    for g in datasets_gen::generators() {
        println!(
            "  {:<16} {:>9} tets  {}",
            g.name, g.default_tets, g.description
        );
    }
}
