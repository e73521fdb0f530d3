//! The whole-tet rasteriser of cpu-pt's fast path (`render::pt::TetRaster`) against the per-triangle
//! one (`render::pt::raster_fan`, the general path's and the definition of coverage) on every tet of a
//! real mesh as the renderer projects it: the NASA `post` grid (when its file is there) and the
//! `post-like` analogue, at 512², two views, over the whole image and clipped to 64×64 tiles.
//! Same centres, same fan triangles, the same barycentric weights to rounding.

use algorithms::camera::{Camera, Projection, View};
use algorithms::render::pt::{classify, raster_fan, FanGeometry, Fragment, ProjVertex, TetRaster};
use algorithms::{Mesh, TransferFunction};

fn check(name: &str, mesh: &Mesh) {
    let tf = TransferFunction::preset("default").unwrap();
    let c = mesh.bbox().center();
    let map = tf.scalar_map(mesh.scalar_range());
    let inv_l = 1.0 / mesh.diagonal();
    let mut frags = 0usize;
    for view in [View::new(30.0, 20.0), View::new(0.0, 0.0)] {
        let cam = Camera::new(&mesh.bbox(), view, Projection::Ortho, 512, 512);
        for t in mesh.tets() {
            let v = t.map(|v| {
                let p = mesh.positions()[v as usize] - c;
                ProjVertex::project(&cam, p, map.s(mesh.scalars()[v as usize]))
            });
            let th = classify(&v, false, inv_l);
            let g = FanGeometry::new(v.map(|p| p.q), &th);
            let b = g.pixel_bounds();
            let tile = [
                b[0].div_euclid(64) * 64,
                b[1].div_euclid(64) * 64,
                b[0].div_euclid(64) * 64 + 63,
                b[1].div_euclid(64) * 64 + 63,
            ];
            for clip in [[0, 0, 511, 511], tile] {
                let mut want: Vec<Fragment> = Vec::new();
                raster_fan(&g, clip, |f| want.push(f));
                let mut got = Vec::new();
                if let Some(r) = TetRaster::new(g.case, &g.q, clip) {
                    r.fragments(|f| got.push(f));
                }
                want.sort_by_key(|f| (f.j, f.i));
                assert_eq!(
                    got.len(),
                    want.len(),
                    "{name} {view:?} {:?} clip {clip:?}",
                    g.q
                );
                for (a, b) in got.iter().zip(&want) {
                    assert_eq!((a.i, a.j, a.tri), (b.i, b.j, b.tri), "{name} {:?}", g.q);
                    assert!((a.lx - b.lx).abs() < 1e-9 && (a.ly - b.ly).abs() < 1e-9);
                }
                frags += got.len();
            }
        }
    }
    assert!(frags > 100_000, "{name}: {frags} fragments");
}

#[test]
fn tet_rasteriser_covers_what_the_fan_rasteriser_does_on_post() {
    let analogue = datasets_gen::generate("post-like", Some(60_000), 1).unwrap();
    check("post-like", &analogue);
    if let Some(post) = tetbench_tests::test_util::nasa("post") {
        check("post", &post);
    }
}
