//! `datasets-gen NAME:N --out FILE` holds one mesh: the writer streams from it, so writing
//! adds a buffer, not a copy. Measured by the counting allocator around the generator and the
//! writer (what the binary runs), on a moderate N in each format.
//!
//! One test in this binary, so that nothing else allocates while it measures.

use algorithms::util::alloc::{measure, CountingAlloc};

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

#[test]
fn writing_a_generated_mesh_adds_no_copy() {
    let dir = std::env::temp_dir().join(format!("datasets-gen-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (name, n) = datasets_gen::parse_spec("brain:300000").unwrap();
    let (mesh, _, gen_peak) = measure(|| datasets_gen::generate(name, n, 1).unwrap());
    let bytes = mesh.data_bytes();
    println!(
        "{name}: {} tets, mesh {bytes} bytes, generation peak {gen_peak} ({:.2}×)",
        mesh.num_tets(),
        gen_peak as f64 / bytes as f64
    );
    for ext in algorithms::io::writers::FORMATS {
        let path = dir.join(format!("m.{ext}"));
        let (r, left, peak) = measure(|| algorithms::io::write(&mesh, &path));
        r.unwrap();
        println!("{ext}: writing peaks {peak} bytes above the mesh, leaves {left}");
        // A write buffer and the XML head: far below a tenth of the mesh, never a copy.
        assert!(
            (peak as f64) < 0.1 * bytes as f64,
            "{ext}: writing peaked {peak} bytes above a mesh of {bytes}"
        );
        std::fs::remove_file(&path).unwrap();
    }
    std::fs::remove_dir_all(&dir).ok();
}
