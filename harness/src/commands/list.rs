//! `tetbench list`: every registered renderer, sort, integrator, preset, GPU adapter and dataset.

use algorithms::{io, optics, render, tf};

pub(super) fn list() {
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
