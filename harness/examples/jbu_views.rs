//! View-by-view comparison of the JBU filters on the paper's 14 cube views (a measurement tool,
//! not part of the harness's commands).
//!
//! cargo run --release -p tetbench --example jbu_views -- \
//!     RENDERER FULL LOWS DATASETS METHODS [DUMP_DIR]
//! e.g. `raycast 512 64,128,256 blunt,post linear,bilateral,gauss,bilateral:s=0.003 /tmp/jbu`.
//! A method is `name[:k=K][:s=SIGMA][:r=R]`. Prints one line per view and a summary per
//! (dataset, low size): mean and worst RMSE per method and the views where it loses to linear.
//! With DUMP_DIR, writes the reference and each method's image for every view as PNG;
//! `JBU_VIEWS=n` keeps the first n views.

use std::time::Instant;

use algorithms::camera::{Camera, Projection};
use algorithms::render::jbu::{cube_views, low_camera, Params, Upsampler};
use algorithms::render::{self, RenderOptions};
use algorithms::{metrics, TransferFunction};
use tetbench::meshes::{load_mesh, MeshSpec};

fn parse_method(s: &str) -> Params {
    Params::from_spec(s).unwrap_or_else(|e| panic!("{e}"))
}

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let rname = &a[0];
    let full: u32 = a[1].parse().unwrap();
    let lows: Vec<u32> = a[2].split(',').map(|s| s.parse().unwrap()).collect();
    let datasets: Vec<&str> = a[3].split(',').collect();
    let mnames: Vec<&str> = a[4].split(',').collect();
    let dump = a.get(5).map(std::path::PathBuf::from);
    let tf = TransferFunction::load("default").unwrap();
    for ds in datasets {
        let mesh = load_mesh(&MeshSpec::named(ds)).unwrap();
        let mut ups: Vec<Upsampler> = mnames
            .iter()
            .map(|m| Upsampler::new(parse_method(m)).unwrap())
            .collect();
        for u in &mut ups {
            u.prepare(&mesh);
        }
        let mut r = render::make(rname, &RenderOptions::default()).unwrap();
        r.prepare(&mesh, &tf).unwrap();
        // rmse[low][method][view]
        let mut rmse = vec![vec![Vec::new(); mnames.len()]; lows.len()];
        let mut times = vec![vec![(0.0, 0.0); mnames.len()]; lows.len()];
        // JBU_VIEWS=n: only the first n views (for timing runs).
        let mut views = cube_views();
        if let Some(n) = std::env::var("JBU_VIEWS").ok().and_then(|v| v.parse().ok()) {
            views.truncate(n);
        }
        for (vi, v) in views.iter().enumerate() {
            let cam = Camera::new(&mesh.bbox(), *v, Projection::Ortho, full, full);
            let t0 = Instant::now();
            let reference = r.render(&mesh, &cam).unwrap().image;
            let full_ms = t0.elapsed().as_secs_f64() * 1e3;
            if let Some(d) = &dump {
                std::fs::create_dir_all(d).unwrap();
                reference
                    .write(&d.join(format!("{ds}_v{vi}_ref.png")))
                    .unwrap();
            }
            for (li, &low) in lows.iter().enumerate() {
                let lc = low_camera(&mesh, &cam, low, low);
                let t0 = Instant::now();
                let li_img = r.render(&mesh, &lc).unwrap().image;
                let low_ms = t0.elapsed().as_secs_f64() * 1e3;
                let mut line = format!(
                    "{ds} v{vi:2} ({:6.1},{:6.1}) {low:4}->{full} full {full_ms:6.0}ms low {low_ms:5.0}ms",
                    v.azimuth, v.elevation
                );
                for (mi, u) in ups.iter().enumerate() {
                    let o = u.run(&li_img, &lc, &cam).unwrap();
                    let e = metrics::compare(&o.image, &reference).unwrap().rmse;
                    rmse[li][mi].push(e);
                    times[li][mi].0 += o.depth_ms / views.len() as f64;
                    times[li][mi].1 += o.filter_ms / views.len() as f64;
                    line += &format!(" {}={e:.5}", mnames[mi]);
                    if let Some(d) = &dump {
                        o.image
                            .write(&d.join(format!("{ds}_v{vi}_{low}_{}.png", mnames[mi])))
                            .unwrap();
                    }
                }
                println!("{line}");
            }
        }
        for (li, &low) in lows.iter().enumerate() {
            println!("== {ds} {rname} {low}->{full}");
            let lin = mnames.iter().position(|m| *m == "linear");
            for (mi, m) in mnames.iter().enumerate() {
                let e = &rmse[li][mi];
                let mean = e.iter().sum::<f64>() / e.len() as f64;
                let worst = e.iter().cloned().fold(0.0, f64::max);
                let losses: Vec<usize> = match lin {
                    Some(l) => (0..e.len()).filter(|&v| e[v] > rmse[li][l][v]).collect(),
                    None => vec![],
                };
                println!(
                    "   {m:24} mean {mean:.5} worst {worst:.5} depth {:.1}ms filter {:.1}ms loses-to-linear {:?}",
                    times[li][mi].0, times[li][mi].1, losses
                );
            }
        }
    }
}
