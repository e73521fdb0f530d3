//! `exact` and `reference` against the emission–absorption model evaluated in 50-digit
//! arithmetic (`tests/oracle/emission_absorption.py`, mpmath): every ray's premultiplied colour
//! and alpha within 1e-9 absolute per channel.
//!
//! - Rays of segments given as (s_f, s_b, l), composited front to back from `exact`'s segments:
//!   random transfer functions of 2 to 120 points (some a hair apart, τ from 0 to 1e3, zeros
//!   among them), segments thin and thick (optical lengths 1e-10 to 3, so τ·l from 0 to 3000),
//!   constant, nearly constant and wide in s, and beyond the TF's points.
//! - Pixels of `reference` on a small non-convex mesh, ortho and perspective: the oracle
//!   clips each pixel's ray against every tet exactly and integrates the pieces.
//!
//! Needs a Python with mpmath: `TETBENCH_VTK_PYTHON` (CI's VTK venv has it). Without it the
//! tests print "skipped", or fail under `TETBENCH_REQUIRE_VTK=1` (CI sets both).

use std::io::Write;
use std::process::{Command, Stdio};

use algorithms::camera::{Camera, Projection, View};
use algorithms::optics::{composite_under, integrator, Segment};
use algorithms::render::raycast::RayCaster;
use algorithms::render::Renderer;
use algorithms::tf::{TfPoint, TransferFunction};
use tetbench_tests::test_util::vtk_enabled;

/// Largest difference allowed per channel.
const TOL: f64 = 1e-9;

/// The oracle's Python (`TETBENCH_VTK_PYTHON`, as for the VTK peers), or `None` with a line
/// saying that `test` was skipped. Fails under `TETBENCH_REQUIRE_VTK=1` when it is not set or
/// has no mpmath.
fn python(test: &str) -> Option<String> {
    if !vtk_enabled(test) {
        return None;
    }
    let py = std::env::var("TETBENCH_VTK_PYTHON").unwrap();
    let ok = Command::new(&py)
        .args(["-c", "import mpmath, numpy"])
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        let required = std::env::var("TETBENCH_REQUIRE_VTK").is_ok_and(|v| v == "1");
        assert!(
            !required,
            "{test}: {py} has no mpmath or numpy and TETBENCH_REQUIRE_VTK=1"
        );
        eprintln!("{test}: {py} has no mpmath or numpy, skipped");
        return None;
    }
    Some(py)
}

/// Runs the oracle on a JSON job; one `[r, g, b, alpha]` per ray.
fn oracle(py: &str, job: &str) -> Vec<[f64; 4]> {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/oracle/emission_absorption.py");
    let mut child = Command::new(py)
        .arg(script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("oracle starts");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(job.as_bytes())
        .unwrap();
    let out = child.wait_with_output().expect("oracle runs");
    assert!(out.status.success(), "oracle failed");
    let text = String::from_utf8(out.stdout).unwrap();
    let rows: Vec<Vec<String>> = serde_json::from_str(&text).expect("oracle's JSON");
    rows.iter()
        .map(|r| std::array::from_fn(|c| r[c].parse::<f64>().expect("a decimal")))
        .collect()
}

/// Deterministic uniform numbers in [0, 1) (SplitMix64).
struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f()
    }
    fn pick(&mut self, n: usize) -> usize {
        ((self.f() * n as f64) as usize).min(n - 1)
    }
}

/// A random TF of `n` points in [0, 1]: some pairs a hair apart (near-steps), τ 0, 1e3 or
/// log-uniform in [1e-3, 1e3].
fn random_tf(rng: &mut Rng, n: usize) -> TransferFunction {
    let mut s: Vec<f64> = (0..n).map(|_| rng.f()).collect();
    s.sort_by(f64::total_cmp);
    for k in 1..n {
        if rng.f() < 0.15 {
            s[k] = s[k - 1] + 1e-7 * (1.0 + rng.f());
        }
        if s[k] <= s[k - 1] {
            s[k] = s[k - 1].next_up();
        }
    }
    let points = s
        .into_iter()
        .map(|s| {
            let tau = match rng.pick(10) {
                0 | 1 => 0.0,
                2 => 1e3,
                _ => 10f64.powf(rng.range(-3.0, 3.0)),
            };
            TfPoint {
                s,
                rgb: [rng.f(), rng.f(), rng.f()],
                tau,
            }
        })
        .collect();
    TransferFunction {
        name: format!("random-{n}"),
        range: None,
        points,
    }
}

fn tf_json(tf: &TransferFunction) -> String {
    let pts: Vec<String> = tf
        .points
        .iter()
        .map(|p| {
            format!(
                "[{:e},{:e},{:e},{:e},{:e}]",
                p.s, p.rgb[0], p.rgb[1], p.rgb[2], p.tau
            )
        })
        .collect();
    format!("[{}]", pts.join(","))
}

/// Largest difference per channel between `got` and the oracle's `want`, and where.
fn worst(got: &[[f64; 4]], want: &[[f64; 4]]) -> (f64, usize) {
    assert_eq!(got.len(), want.len());
    let mut w = (0.0f64, 0);
    for (k, (g, o)) in got.iter().zip(want).enumerate() {
        for c in 0..4 {
            let d = (g[c] - o[c]).abs();
            if d > w.0 || d.is_nan() {
                w = (d, k);
            }
        }
    }
    w
}

#[test]
fn exact_rays_match_the_fifty_digit_model() {
    let Some(py) = python("exact_rays_match_the_fifty_digit_model") else {
        return;
    };
    let mut rng = Rng(55);
    let mut overall = 0.0f64;
    for n in [2, 3, 5, 12, 40, 120] {
        let tf = random_tf(&mut rng, n);
        let exact = integrator("exact", &tf).unwrap();
        let mut rays: Vec<Vec<(f64, f64, f64)>> = Vec::new();
        for _ in 0..24 {
            let segs = 1 + rng.pick(10);
            let mut s = rng.range(-0.1, 1.1);
            let ray = (0..segs)
                .map(|_| {
                    let sf = s;
                    s = match rng.pick(10) {
                        0 => s,
                        1 => s + 1e-12 * rng.range(-1.0, 1.0),
                        2..=5 => s + rng.range(-0.05, 0.05),
                        _ => rng.range(-0.2, 1.2),
                    };
                    (sf, s, 10f64.powf(rng.range(-10.0, 0.5)))
                })
                .collect();
            rays.push(ray);
        }
        let got: Vec<[f64; 4]> = rays
            .iter()
            .map(|ray| {
                let mut acc = Segment::default();
                for &(sf, sb, l) in ray {
                    composite_under(&mut acc, exact.segment(sf, sb, l));
                }
                [acc.rgb[0], acc.rgb[1], acc.rgb[2], acc.alpha]
            })
            .collect();
        let rays_json: Vec<String> = rays
            .iter()
            .map(|r| {
                let s: Vec<String> = r
                    .iter()
                    .map(|(a, b, l)| format!("[{a:e},{b:e},{l:e}]"))
                    .collect();
                format!("[{}]", s.join(","))
            })
            .collect();
        let job = format!(
            r#"{{"tf":{},"rays":[{}]}}"#,
            tf_json(&tf),
            rays_json.join(",")
        );
        let want = oracle(&py, &job);
        let (d, k) = worst(&got, &want);
        eprintln!("{n} TF points: largest difference {d:.3e}");
        assert!(
            d <= TOL,
            "{n} TF points, ray {k} {:?}: {:?} against the model's {:?}",
            rays[k],
            got[k],
            want[k]
        );
        overall = overall.max(d);
    }
    eprintln!("exact against the 50-digit model: largest difference {overall:.3e}");
}

#[test]
fn reference_pixels_match_the_fifty_digit_model() {
    let Some(py) = python("reference_pixels_match_the_fifty_digit_model") else {
        return;
    };
    let mesh = datasets_gen::generate("spx", Some(1500), 3).unwrap();
    let mut rng = Rng(7);
    let dense = random_tf(&mut rng, 12);
    let mut thick = dense.clone();
    for p in &mut thick.points {
        p.tau = p.tau.min(60.0);
    }
    let cases = [
        (dense, (30.0, 20.0), Projection::Ortho),
        (thick, (157.57, -64.16), Projection::Persp),
    ];
    for (tf, (az, el), proj) in cases {
        let mut rc = RayCaster::new("exact", "reference");
        rc.prepare(&mesh, &tf).unwrap();
        let cam = Camera::new(&mesh.bbox(), View::new(az, el), proj, 20, 20);
        let (px, stats) = rc.render_f64(&mesh, &cam).unwrap();
        assert_eq!(stats.missed, 0);
        let map = tf.scalar_map(mesh.scalar_range());
        let verts: Vec<String> = mesh
            .positions()
            .iter()
            .zip(mesh.scalars())
            .map(|(p, &v)| format!("[{:e},{:e},{:e},{:e}]", p.x, p.y, p.z, map.s(v)))
            .collect();
        let tets: Vec<String> = mesh
            .tets()
            .iter()
            .map(|t| format!("[{},{},{},{}]", t[0], t[1], t[2], t[3]))
            .collect();
        let mut pixels = Vec::new();
        for j in 0..cam.height {
            for i in 0..cam.width {
                let r = cam.pixel_ray(i, j);
                let (o, d) = (r.origin, r.dir);
                pixels.push(format!(
                    "[{:e},{:e},{:e},{:e},{:e},{:e}]",
                    o.x, o.y, o.z, d.x, d.y, d.z
                ));
            }
        }
        let job = format!(
            r#"{{"tf":{},"mesh":{{"verts":[{}],"tets":[{}],"L":{:e}}},"pixels":[{}]}}"#,
            tf_json(&tf),
            verts.join(","),
            tets.join(","),
            mesh.diagonal(),
            pixels.join(",")
        );
        let want = oracle(&py, &job);
        let (d, k) = worst(&px, &want);
        let covered = want.iter().filter(|p| p[3] > 0.0).count();
        eprintln!("{proj:?} view {az},{el}: {covered} pixels covered, largest difference {d:.3e}");
        assert!(covered > 100, "the mesh covers {covered} pixels");
        assert!(
            d <= TOL,
            "{proj:?}: pixel ({}, {}) {:?} against the model's {:?}",
            k as u32 % cam.width,
            k as u32 / cam.width,
            px[k],
            want[k]
        );
    }
}

/// Single pieces at the depths where `exact` changes its quadrature (the `G = g(1)` up to which
/// each Gauss–Legendre rule of `algorithms/src/optics/gauss.rs` is used, and where the last one
/// hands over to Ψ's panels), just below and above each, in the middle of each band, and far
/// thinner (τ·l down to 1e-300): with one end's τ 0, equal ends and random ratios, front to back
/// and back to front, and pieces that start or end on a TF point. Each is held to 1e-11, the
/// quadrature's bound (1e-12 of the piece's opacity for each of its two integrals) with room
/// for the oracle's inputs' last bits; the rays to the contract's 1e-9.
#[test]
fn exact_pieces_at_the_quadrature_bounds_match_the_fifty_digit_model() {
    let Some(py) = python("exact_pieces_at_the_quadrature_bounds_match_the_fifty_digit_model")
    else {
        return;
    };
    const BOUNDS: [f64; 8] = [2.4e-3, 2.4e-2, 9.3e-2, 0.22, 0.40, 0.89, 1.49, 2.88];
    let mut rng = Rng(1955);
    let mut depths: Vec<f64> = vec![1e-300, 1e-100, 1e-30, 1e-14, 1e-8, 1e-5, 3.0, 5.0, 40.0];
    let mut lo = 1e-5;
    for &b in &BOUNDS {
        depths.extend([
            b * (1.0 - 1e-12),
            b,
            b * (1.0 + 1e-12),
            b * 1.01,
            (lo * b).sqrt(),
        ]);
        lo = b;
    }
    // TF points at 0 and 1 (and a middle one for the pieces that meet a point).
    for ratio in [0.0, 1.0, 0.37, 2.9, -1.0] {
        let r = if ratio < 0.0 { rng.f() } else { ratio };
        let (t0, t1) = (1.0, r);
        let tf = TransferFunction {
            name: "two".into(),
            range: None,
            points: vec![
                TfPoint {
                    s: 0.0,
                    rgb: [0.9, 0.1, 0.5],
                    tau: t0,
                },
                TfPoint {
                    s: 0.5,
                    rgb: [0.3, 0.8, 0.2],
                    tau: 0.5 * (t0 + t1),
                },
                TfPoint {
                    s: 1.0,
                    rgb: [0.1, 0.6, 1.0],
                    tau: t1,
                },
            ],
        };
        let exact = integrator("exact", &tf).unwrap();
        // Segments of one piece (and one of two, split at 0.5) of optical depth G = τ̄·l.
        let tau = |s: f64| tf.eval(s).1;
        let mut segs: Vec<(f64, f64, f64)> = Vec::new();
        for &g in &depths {
            for (sf, sb) in [
                (0.0, 0.5),
                (0.5, 0.0),
                (0.5, 1.0),
                (1.0, 0.5),
                (0.2, 0.5),
                (0.5, 0.5),
                (0.0, 1.0),
            ] {
                let mean = 0.5 * (tau(sf) + tau(sb));
                if mean > 0.0 {
                    segs.push((sf, sb, g / mean));
                }
            }
        }
        let got: Vec<[f64; 4]> = segs
            .iter()
            .map(|&(sf, sb, l)| {
                let s = exact.segment(sf, sb, l);
                [s.rgb[0], s.rgb[1], s.rgb[2], s.alpha]
            })
            .collect();
        let rays: Vec<String> = segs
            .iter()
            .map(|(a, b, l)| format!("[[{a:e},{b:e},{l:e}]]"))
            .collect();
        let job = format!(r#"{{"tf":{},"rays":[{}]}}"#, tf_json(&tf), rays.join(","));
        let want = oracle(&py, &job);
        let (d, k) = worst(&got, &want);
        eprintln!("τ ratio {r}: largest difference {d:.3e}");
        assert!(
            d <= 1e-11,
            "τ ratio {r}, piece {:?}: {:?} against the model's {:?}",
            segs[k],
            got[k],
            want[k]
        );
    }
}
