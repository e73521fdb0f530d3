//! Prints size, validity figures and generation time for every generator:
//! `cargo run --release -p datasets-gen --example stats [-- TETS|default [NAME_PREFIX]]`.
fn main() {
    let size = std::env::args().nth(1).unwrap_or_else(|| "20000".into());
    let prefix = std::env::args().nth(2).unwrap_or_default();
    for g in datasets_gen::generators() {
        if !g.name.starts_with(&prefix) {
            continue;
        }
        let n = match size.as_str() {
            "default" => None,
            s => Some(if g.name == "hard-saturate" {
                40
            } else {
                s.parse().unwrap()
            }),
        };
        let t = std::time::Instant::now();
        let r = datasets_gen::generate_checked(g.name, n, 1).unwrap();
        let dt = t.elapsed().as_secs_f64();
        let m = &r.mesh;
        let v = m.volumes();
        let max = v.iter().cloned().fold(0.0, f64::max);
        let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
        println!(
            "{:18} tets {:8} verts {:8} boundary {:7}/{:7?} degenerate {} negative {} convex {} minvol/maxvol {:.1e} {:.2}s",
            g.name,
            m.num_tets(),
            m.num_vertices(),
            m.boundary_faces().len(),
            r.expected_boundary_faces,
            m.degenerate_tets(),
            m.negative_tets(),
            m.is_convex(),
            min / max,
            dt
        );
    }
}
