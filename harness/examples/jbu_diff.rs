//! Where one JBU method loses to another, pixel by pixel (a measurement tool, not part of the
//! harness's commands; `jbu_views` gives the view-by-view summary).
//!
//! cargo run --release -p tetbench --example jbu_diff -- \
//!     RENDERER FULL LOW DATASET VIEW A B OUT.png
//! e.g. `cpu-pt 1024 128 comb 2 linear bilateral comb2.png` (VIEW indexes `jbu::cube_views`).
//! Prints both RMSEs (summed over RGBA), the squared error of A and B per class of pixel (its
//! number of boundary crossings, and those of its four low-res samples), the worst pixels for
//! B, and writes a map: red where B is worse, green where it is better, over the dimmed image.
//! `PROBE="i,j;..."` prints each pixel's layers, its samples and both results;
//! `MAXD=x` fixes the map's scale; `TIMES=n` times each method n more times (minimum of the depth and filter stages).
use algorithms::camera::{Camera, Projection};
use algorithms::image::Image;
use algorithms::render::jbu::{cube_views, low_camera, BoundaryRaster, Params, Upsampler};
use algorithms::render::{self, RenderOptions};
use algorithms::TransferFunction;
use std::collections::BTreeMap;
use tetbench::meshes::{load_mesh, MeshSpec};

fn parse_method(s: &str) -> Params {
    Params::from_spec(s).unwrap_or_else(|e| panic!("{e}"))
}

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let full: u32 = a[1].parse().unwrap();
    let low: u32 = a[2].parse().unwrap();
    let mesh = load_mesh(&MeshSpec::named(&a[3])).unwrap();
    let vi: usize = a[4].parse().unwrap();
    let tf = TransferFunction::load("default").unwrap();
    let mut r = render::make(&a[0], &RenderOptions::default()).unwrap();
    r.prepare(&mesh, &tf).unwrap();
    let v = cube_views()[vi];
    let cam = Camera::new(&mesh.bbox(), v, Projection::Ortho, full, full);
    let reference = r.render(&mesh, &cam).unwrap().image;
    let lc = low_camera(&mesh, &cam, low, low);
    let li = r.render(&mesh, &lc).unwrap().image;
    if let Some(n) = std::env::var("TIMES")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        let mut best = f64::INFINITY;
        for _ in 0..n {
            let t0 = std::time::Instant::now();
            r.render(&mesh, &lc).unwrap();
            best = best.min(t0.elapsed().as_secs_f64() * 1e3);
        }
        println!("low-res render ({low}²): min of {n}: {best:.1} ms");
    }
    let mut out = vec![];
    let times: usize = std::env::var("TIMES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    for m in [&a[5], &a[6]] {
        let mut u = Upsampler::new(parse_method(m)).unwrap();
        u.prepare(&mesh);
        out.push(u.run(&li, &lc, &cam).unwrap().image);
        if times > 0 {
            let (mut d, mut f) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..times {
                let o = u.run(&li, &lc, &cam).unwrap();
                d = d.min(o.depth_ms);
                f = f.min(o.filter_ms);
            }
            println!("{m}: min of {times}: depth {d:.1} ms, filter {f:.1} ms");
        }
    }
    let br = BoundaryRaster::new(&mesh);
    let fl = br.layers(&cam, 4);
    let ll = br.layers(&lc, 4);
    let scale = cam.pixel / lc.pixel;
    let e2 = |img: &Image, i: u32, j: u32| -> f64 {
        let p = img.get(i, j);
        let q = reference.get(i, j);
        (0..4).map(|c| ((p[c] - q[c]) as f64).powi(2)).sum()
    };
    let mut by: BTreeMap<String, (usize, f64, f64)> = BTreeMap::new();
    let mut d = vec![0f64; (full * full) as usize];
    let (mut ta, mut tb) = (0.0, 0.0);
    for j in 0..full {
        for i in 0..full {
            let ea = e2(&out[0], i, j);
            let eb = e2(&out[1], i, j);
            ta += ea;
            tb += eb;
            d[(j * full + i) as usize] = eb - ea;
            let np = fl.count[(j * full + i) as usize];
            let u = (i as f64 + 0.5 - 0.5 * full as f64) * scale + 0.5 * low as f64 - 0.5;
            let w = (j as f64 + 0.5 - 0.5 * full as f64) * scale + 0.5 * low as f64 - 0.5;
            let (x0, y0) = (
                u.floor().clamp(0.0, (low - 1) as f64) as u32,
                w.floor().clamp(0.0, (low - 1) as f64) as u32,
            );
            let mut cs = vec![];
            for (x, y) in [
                (x0, y0),
                ((x0 + 1).min(low - 1), y0),
                (x0, (y0 + 1).min(low - 1)),
                ((x0 + 1).min(low - 1), (y0 + 1).min(low - 1)),
            ] {
                cs.push(ll.count[(y * low + x) as usize]);
            }
            cs.sort();
            cs.dedup();
            let key = format!("np={np} low={cs:?}");
            let e = by.entry(key).or_insert((0, 0.0, 0.0));
            e.0 += 1;
            e.1 += ea;
            e.2 += eb;
        }
    }
    if let Ok(pr) = std::env::var("PROBE") {
        for pp in pr.split(';') {
            let (i, j) = pp.split_once(',').unwrap();
            let (i, j): (u32, u32) = (i.parse().unwrap(), j.parse().unwrap());
            let u = (i as f64 + 0.5 - 0.5 * full as f64) * scale + 0.5 * low as f64 - 0.5;
            let w = (j as f64 + 0.5 - 0.5 * full as f64) * scale + 0.5 * low as f64 - 0.5;
            println!(
                "pixel {i},{j} low ({u:.3},{w:.3}) count {} layers {:?}",
                fl.count[(j * full + i) as usize],
                fl.at(i, j)
            );
            println!(
                "   ref {:?} A {:?} B {:?}",
                reference.get(i, j),
                out[0].get(i, j),
                out[1].get(i, j)
            );
            let (x0, y0) = (u.floor() as u32, w.floor() as u32);
            for (x, y) in [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)] {
                println!(
                    "   low {x},{y} count {} layers {:?} colour {:?}",
                    ll.count[(y * low + x) as usize],
                    ll.at(x, y),
                    li.get(x, y)
                );
            }
            for di in [-2i32, -1, 1, 2] {
                let ii = (i as i32 + di) as u32;
                println!(
                    "   nb {ii},{j} count {} layers {:?}",
                    fl.count[(j * full + ii) as usize],
                    fl.at(ii, j)
                );
            }
        }
    }
    let n = (full * full) as f64;
    println!("rmse A {:.4e} B {:.4e}", (ta / n).sqrt(), (tb / n).sqrt());
    let mut v: Vec<_> = by.into_iter().collect();
    v.sort_by(|x, y| {
        ((y.1 .2 - y.1 .1).abs())
            .partial_cmp(&(x.1 .2 - x.1 .1).abs())
            .unwrap()
    });
    for (k, (c, ea, eb)) in v.iter().take(25) {
        println!(
            "{k:32} n {c:7} sumA {ea:.3e} sumB {eb:.3e} B-A {:+.3e}",
            eb - ea
        );
    }
    let mut order: Vec<usize> = (0..d.len()).collect();
    order.sort_by(|&x, &y| d[y].partial_cmp(&d[x]).unwrap());
    println!(
        "worst pixels: {}",
        order
            .iter()
            .take(12)
            .map(|&o| format!("{},{}", o as u32 % full, o as u32 / full))
            .collect::<Vec<_>>()
            .join(";")
    );
    // The map's scale: `MAXD` (to compare two maps), else this map's largest difference.
    let mx = std::env::var("MAXD")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| d.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-30));
    println!("map scale (largest |B-A| per pixel): {mx:.3e}");
    let mut img = Image::new(full, full);
    for j in 0..full {
        for i in 0..full {
            let x = d[(j * full + i) as usize] / mx;
            let s = x.abs().sqrt() as f32;
            let g = reference.get(i, j);
            let base = 0.25 * (g[0] + g[1] + g[2]) / 3.0;
            img.pixels[(j * full + i) as usize] = if x > 0.0 {
                [s.max(base), base, base, 1.0]
            } else {
                [base, s.max(base), base, 1.0]
            };
        }
    }
    img.write(std::path::Path::new(&a[7])).unwrap();
}
