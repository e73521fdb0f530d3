//! Unit tests of `xmpvo`: the exterior constraints on tiny meshes, and bad input.

use glam::DVec3;

use super::*;
use crate::camera::View;
use crate::Error;

fn mesh(pos: Vec<DVec3>, tets: Vec<[u32; 4]>) -> Mesh {
    let s = vec![0.0; pos.len()];
    Mesh::with_scalars("xmpvo-test", pos, tets, "s", s).unwrap()
}

fn unit_tet(o: DVec3, scale: f64) -> [DVec3; 4] {
    [
        o,
        o + scale * DVec3::X,
        o + scale * DVec3::Y,
        o + scale * DVec3::Z,
    ]
}

fn run(mesh: &Mesh, cam: &Camera) -> (Vec<u32>, SortStats) {
    let mut s = Xmpvo::default();
    s.prepare(mesh).unwrap();
    let mut order = Vec::new();
    let stats = s.sort(mesh, cam, &mut order).unwrap();
    let mut seen = vec![false; mesh.num_tets()];
    for &t in &order {
        assert!(!seen[t as usize], "tet {t} twice");
        seen[t as usize] = true;
    }
    assert_eq!(order.len(), mesh.num_tets());
    (order, stats)
}

#[test]
fn one_tet_enters_then_exits_everywhere() {
    let m = mesh(unit_tet(DVec3::ZERO, 1.0).to_vec(), vec![[0, 1, 2, 3]]);
    for view in [View::new(10.0, 20.0), View::new(200.0, -40.0)] {
        for proj in [Projection::Ortho, Projection::Persp] {
            let cam = Camera::new(&m.bbox(), view, proj, 32, 32);
            let mut s = Xmpvo::default();
            s.prepare(&m).unwrap();
            let ext = exterior(&cam, &s.bpos, &s.bfaces).unwrap();
            assert!(ext.hits > 20, "{view:?} {proj:?}: {} hits", ext.hits);
            assert_eq!(ext.irregular_pixels, 0, "{view:?} {proj:?}");
            assert!(ext.edges.is_empty());
            // Inverted orientation: the kinds follow the tet's sign.
            let inv = mesh(unit_tet(DVec3::ZERO, 1.0).to_vec(), vec![[0, 2, 1, 3]]);
            s.prepare(&inv).unwrap();
            let ext = exterior(&cam, &s.bpos, &s.bfaces).unwrap();
            assert_eq!(ext.irregular_pixels, 0, "inverted {view:?} {proj:?}");
        }
    }
}

#[test]
fn a_cell_hidden_across_empty_space_comes_first() {
    // Two disjoint tets and no face between them: a long slanted tet A (z from 0 up to 30 at
    // x = 10) and a small tet B floating above A's low end (z 3..3.3 where A is below 2.4).
    // Seen from +z, A is behind B where they overlap, though A's centroid (z 7.75) is nearer
    // than B's: the centroid order, and so MPVONC's source order, is wrong from both sides.
    let mut pos = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(10.0, 0.0, 30.0),
        DVec3::new(0.0, 3.0, 0.0),
        DVec3::new(0.0, 0.0, 1.0),
    ];
    pos.extend(unit_tet(DVec3::new(0.2, 0.3, 3.0), 0.3));
    let m = mesh(pos, vec![[0, 1, 2, 3], [4, 5, 6, 7]]);
    for proj in [Projection::Ortho, Projection::Persp] {
        // View (0, 0) looks from +z, (180, 0) from −z.
        for (view, right) in [
            (View::new(0.0, 0.0), [0, 1]),
            (View::new(180.0, 0.0), [1, 0]),
        ] {
            let cam = Camera::new(&m.bbox(), view, proj, 256, 256);
            let (order, stats) = run(&m, &cam);
            assert_eq!(order, right, "{view:?} {proj:?}");
            assert_eq!(stats.exterior_edges, 1, "{view:?} {proj:?}");
            let mut mpvonc = super::super::Mpvonc::default();
            mpvonc.prepare(&m).unwrap();
            let mut wrong = Vec::new();
            mpvonc.sort(&m, &cam, &mut wrong).unwrap();
            assert_ne!(wrong, right, "the configuration should defeat mpvonc");
        }
    }
}

#[test]
fn a_mesh_without_boundary_is_a_counted_cycle() {
    // A tet and its copy: every face is glued twice, there is no boundary, and the faces
    // constrain the two copies both ways.
    let m = mesh(
        unit_tet(DVec3::ZERO, 1.0).to_vec(),
        vec![[0, 1, 2, 3], [0, 1, 2, 3]],
    );
    assert!(m.boundary_faces().is_empty());
    let cam = Camera::new(&m.bbox(), View::new(30.0, 20.0), Projection::Ortho, 16, 16);
    let (_, stats) = run(&m, &cam);
    assert_eq!(stats.exterior_edges, 0);
    assert_eq!((stats.cycles, stats.cells_in_cycles), (1, 2));
    assert!(stats.forced >= 1);
}

#[test]
fn non_manifold_and_overlapping_cells_are_counted_and_ordered() {
    // Three copies of a tet meet at every face (the third copy's faces count as boundary), and
    // a fourth tet overlaps them without sharing a face: along the rays through the overlap the
    // crossings go entry, entry, exit, exit — no order is right there, and it is counted.
    let mut pos = unit_tet(DVec3::ZERO, 1.0).to_vec();
    pos.extend(unit_tet(DVec3::splat(0.2), 1.0));
    let m = mesh(
        pos,
        vec![[0, 1, 2, 3], [0, 1, 2, 3], [0, 1, 2, 3], [4, 5, 6, 7]],
    );
    assert!(m.adjacency().nonmanifold_faces > 0);
    for proj in [Projection::Ortho, Projection::Persp] {
        let cam = Camera::new(&m.bbox(), View::new(30.0, 20.0), proj, 24, 24);
        let (_, stats) = run(&m, &cam);
        assert!(stats.irregular_pixels > 0, "{proj:?} {stats:?}");
        assert!(stats.cycles > 0, "{proj:?} {stats:?}");
    }
}

#[test]
fn an_image_too_large_for_the_lists_is_refused_by_size() {
    let mut pos = unit_tet(DVec3::ZERO, 1.0).to_vec();
    pos.push(DVec3::new(1.0, 1.0, 1.0));
    let m = mesh(pos, vec![[0, 1, 2, 3], [1, 2, 3, 4]]);
    let cam = Camera::new(
        &m.bbox(),
        View::new(0.0, 0.0),
        Projection::Ortho,
        32768,
        32768,
    );
    let mut s = Xmpvo::default();
    s.prepare(&m).unwrap();
    let mut order = Vec::new();
    let err = s.sort(&m, &cam, &mut order).unwrap_err();
    assert!(matches!(err, Error::Input(_)), "{err}");
    let msg = err.to_string();
    assert!(msg.contains("32768x32768") && !msg.contains('\n'), "{msg}");
    // The same mesh at an ordinary size sorts.
    let cam = Camera::new(&m.bbox(), View::new(0.0, 0.0), Projection::Ortho, 512, 512);
    run(&m, &cam);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig {
        failure_persistence: None,
        cases: 64, // or $PROPTEST_CASES
        ..Default::default()
    })]
    /// Arbitrary soups of tets on a small vertex grid — duplicates, overlaps, shared and
    /// non-manifold faces, flat and zero-volume tets, meshes with no boundary — at an arbitrary
    /// view, ortho or persp: `xmpvo` returns a permutation (checked by `run`), never a panic or a
    /// hang, and what it could not order is counted.
    #[test]
    fn any_tet_soup_gets_a_permutation(
        tets in proptest::collection::vec(proptest::array::uniform4(0u32..12), 1..24),
        az in -180.0f64..180.0,
        el in -89.0f64..89.0,
        persp in proptest::bool::ANY,
    ) {
        // 12 vertices on a 3×2×2 grid, so coplanar and collinear quadruples are common.
        let pos: Vec<DVec3> = (0..12)
            .map(|k| DVec3::new((k % 3) as f64, ((k / 3) % 2) as f64, (k / 6) as f64))
            .collect();
        let Ok(m) = Mesh::with_scalars("soup", pos, tets, "s", vec![0.0; 12]) else {
            return Ok(()); // refused by the mesh checks (e.g. a repeated vertex in a tet)
        };
        let proj = if persp { Projection::Persp } else { Projection::Ortho };
        let cam = Camera::new(&m.bbox(), View::new(az, el), proj, 20, 20);
        let (_, stats) = run(&m, &cam);
        // The fallback forces a cell for every stall, and only inside counted cycles' reach.
        proptest::prop_assert!(stats.cells_in_cycles <= m.num_tets());
        proptest::prop_assert!(stats.forced == 0 || stats.cycles > 0, "{stats:?}");
    }
}
