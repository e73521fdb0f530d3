//! Every generator at a small size: tet count within 3 % of the request, positive volumes
//! (except what a hard case means to break), conforming faces (no face met by three tets, and
//! exactly the boundary faces the construction implies), deterministic for a seed.

use algorithms::Mesh;
use datasets_gen::{generate, generate_checked, generators, Lattice, LatticeKind, LATTICE_KEY};

/// Small test sizes (the whole suite must stay fast).
fn test_size(name: &str) -> usize {
    match name {
        "hard-saturate" => 40,
        "hard-cycle" => 300,
        "spx" => 13_000,
        _ => 6_000,
    }
}

fn check(name: &str, tets: usize) -> Mesh {
    let g = generate_checked(name, Some(tets), 7).unwrap_or_else(|e| panic!("{name}: {e}"));
    let m = g.mesh;
    let n = m.num_tets();
    let err = (n as f64 - tets as f64).abs() / tets as f64;
    assert!(
        err <= 0.03,
        "{name}: {n} tets for {tets} asked ({:.1} %)",
        100.0 * err
    );

    // Volumes.
    let vols = m.volumes();
    let (degenerate, negative) = (m.degenerate_tets(), m.negative_tets());
    match name {
        "hard-zero-volume" => {
            assert!(degenerate > 0, "{name}: no zero-volume tets");
            assert_eq!(negative, 0, "{name}");
            assert!(vols.iter().all(|&v| v >= 0.0), "{name}");
        }
        "hard-negative" => {
            assert_eq!(negative, n / 2, "{name}");
            assert_eq!(degenerate, 0, "{name}");
        }
        _ => {
            let bad = vols.iter().filter(|&&v| v <= 0.0).count();
            assert_eq!(bad, 0, "{name}: {bad} tets with volume <= 0");
            assert_eq!(degenerate, 0, "{name}");
        }
    }

    // Conforming faces.
    let adj = m.adjacency();
    assert_eq!(
        adj.nonmanifold_faces, 0,
        "{name}: faces met by three or more tets"
    );
    // Neighbour relation is symmetric.
    for (t, nb) in adj.neighbors.iter().enumerate() {
        for &o in nb {
            if o != algorithms::mesh::BOUNDARY {
                assert!(adj.neighbors[o as usize].contains(&(t as u32)), "{name}");
            }
        }
    }
    let expected = g
        .expected_boundary_faces
        .expect("every generator says its boundary");
    assert_eq!(
        m.boundary_faces().len(),
        expected,
        "{name}: boundary faces (non-conforming interior faces show up as extra boundary)"
    );
    m
}

#[test]
fn every_generator_is_valid_at_a_small_size() {
    for g in generators() {
        check(g.name, test_size(g.name));
    }
}

#[test]
fn sizes_other_than_the_test_size_hit_the_count() {
    for (name, n) in [
        ("cc5", 2_345),
        ("cc6", 10_001),
        ("bcc", 4_567),
        ("fighter", 20_000),
        ("post-like", 9_000),
        ("torus", 3_000),
    ] {
        check(name, n);
    }
}

#[test]
fn generators_are_deterministic_for_a_seed() {
    for g in generators() {
        let n = test_size(g.name).min(3_000);
        let a = generate(g.name, Some(n), 11).unwrap();
        let b = generate(g.name, Some(n), 11).unwrap();
        assert_eq!(a.positions(), b.positions(), "{}", g.name);
        assert_eq!(a.tets(), b.tets(), "{}", g.name);
        assert_eq!(a.fields(), b.fields(), "{}", g.name);
        assert_eq!(a.field_data, b.field_data, "{}", g.name);
    }
    // The seed matters where there is randomness (jitter, Gaussian centres).
    let a = generate("spx", Some(3_000), 1).unwrap();
    let b = generate("spx", Some(3_000), 2).unwrap();
    assert_ne!(a.positions(), b.positions());
}

#[test]
fn names_and_defaults() {
    let gens = generators();
    let names: Vec<&str> = gens.iter().map(|g| g.name).collect();
    for want in [
        "cc5",
        "cc6",
        "bcc",
        "spx",
        "spx2",
        "delta",
        "torso",
        "fighter",
        "fuel",
        "brain",
        "blunt-like",
        "comb-like",
        "post-like",
        "tv-gaussian",
        "torus",
        "shell",
    ] {
        assert!(names.contains(&want), "{want} missing");
    }
    for (name, tets) in [
        ("spx", 13_000),
        ("spx2", 828_000),
        ("delta", 1_000_000),
        ("torso", 1_080_000),
        ("fighter", 1_400_000),
        ("fuel", 1_500_000),
        ("brain", 5_500_000),
        ("blunt-like", 187_000),
        ("comb-like", 215_000),
        ("post-like", 513_000),
    ] {
        assert_eq!(datasets_gen::find(name).unwrap().default_tets, tets);
    }
    for g in gens {
        assert_eq!(
            g.name.starts_with("hard-"),
            g.breaks.is_some(),
            "{}",
            g.name
        );
        assert!(!g.description.is_empty());
    }
    let mut sorted = names.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted.len(), names.len(), "duplicate names");
    let e = generate("nope", None, 0).unwrap_err();
    assert!(matches!(e, algorithms::Error::Input(_)));
    assert!(
        e.to_string().contains("cc5") && e.to_string().contains("hard-cycle"),
        "{e}"
    );
    assert!(generate("cc5", Some(0), 0).is_err());
    // The bound is checked before anything is built: one past it is refused at once.
    let e = generate("brain", Some(datasets_gen::MAX_TETS + 1), 0).unwrap_err();
    assert!(matches!(e, algorithms::Error::Input(_)), "{e}");
}

#[test]
fn at_least_half_the_analogues_are_non_convex() {
    let analogues = [
        "spx",
        "spx2",
        "delta",
        "torso",
        "fighter",
        "fuel",
        "brain",
        "blunt-like",
        "comb-like",
        "post-like",
    ];
    let non_convex = analogues
        .iter()
        .filter(|n| !generate(n, Some(4_000), 0).unwrap().is_convex())
        .count();
    assert!(non_convex * 2 >= analogues.len(), "{non_convex} non-convex");
    assert!(generate("cc6", Some(4_000), 0).unwrap().is_convex());
    assert!(!generate("torus", Some(4_000), 0).unwrap().is_convex());
    assert!(!generate("shell", Some(4_000), 0).unwrap().is_convex());
}

#[test]
fn lattice_description_travels_with_the_mesh() {
    for (name, kind) in [
        ("cc5", LatticeKind::Cc5),
        ("cc6", LatticeKind::Cc6),
        ("bcc", LatticeKind::Bcc),
    ] {
        let m = generate(name, Some(5_000), 0).unwrap();
        let l = Lattice::from_field_data(&m.field_data[LATTICE_KEY]).unwrap();
        assert_eq!(l.kind, kind);
        assert_eq!(l.num_tets(), m.num_tets(), "{name}");
        // Vertex (i, j, k) of the (primary) grid is at origin + spacing·(i, j, k).
        let [nx, ny, nz] = l.n;
        for (i, j, k) in [(0, 0, 0), (nx - 1, 0, 0), (1, ny - 1, nz - 1)] {
            let v = i + nx * (j + ny * k);
            let want = l.origin + l.spacing * glam::DVec3::new(i as f64, j as f64, k as f64);
            assert!(
                (m.positions()[v] - want).length() < 1e-12,
                "{name} vertex {v}"
            );
        }
    }
    // BCC: each tet has two primary and two secondary vertices, all of volume h³/12.
    let m = generate("bcc", Some(5_000), 0).unwrap();
    let l = Lattice::from_field_data(&m.field_data[LATTICE_KEY]).unwrap();
    let nprim = (l.n[0] * l.n[1] * l.n[2]) as u32;
    let h3 = l.spacing.x * l.spacing.y * l.spacing.z;
    for (t, tet) in m.tets().iter().enumerate() {
        assert!(tet[0] < nprim && tet[1] < nprim && tet[2] >= nprim && tet[3] >= nprim);
        assert!((m.volumes()[t] - h3 / 12.0).abs() < 1e-12 * h3);
    }
    // Equal information: the default bcc has about 29.3 % fewer samples than the default cc.
    let cc = 41usize.pow(3) as f64;
    let bcc_n = 29usize.pow(3) as f64;
    assert!((bcc_n * 2.0 / cc - 0.707).abs() < 0.03 * 2.0);
}

#[test]
fn tv_gaussian_has_steps_and_streams() {
    let m = generate("tv-gaussian", Some(3_000), 0).unwrap();
    let f = &m.fields()[0];
    assert_eq!(f.steps.len(), datasets_gen::TV_STEPS);
    assert_ne!(f.steps[0], f.steps[1]);
    assert_eq!(
        f.steps[5],
        datasets_gen::tv_gaussian_step(m.positions(), 5, datasets_gen::TV_STEPS)
    );
}

#[test]
fn hard_cases_do_what_they_say() {
    let t = generate("hard-translated", Some(3_000), 0).unwrap();
    assert!(t.bbox().min.x > 1e6 - 1.5);
    let s = generate("hard-tiny", Some(3_000), 0).unwrap();
    assert!(s.diagonal() < 1e-5);
    let r = generate("hard-scalar-range", Some(3_000), 0).unwrap();
    assert!(r.scalar_range().1 / r.scalar_range().0 > 1e25);
    let c = generate("hard-constant", Some(3_000), 0).unwrap();
    assert_eq!(c.scalar_range(), (1.0, 1.0));
    let d = generate("hard-duplicates", Some(3_000), 0).unwrap();
    let mut p: Vec<[u64; 3]> = d
        .positions()
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect();
    let before = p.len();
    p.sort();
    p.dedup();
    assert!(p.len() < before, "no duplicate vertices");
    // Thin layers: slivers, needles and caps have tiny volume relative to their edges.
    for name in ["hard-slivers", "hard-needles", "hard-caps"] {
        let m = generate(name, Some(3_000), 0).unwrap();
        let v = m.volumes();
        let max = v.iter().cloned().fold(0.0, f64::max);
        let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(min > 0.0 && min < 1e-3 * max, "{name}: {min} vs {max}");
    }
}
