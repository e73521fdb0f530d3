//! `cargo test --release -p datasets-gen --test timing -- --ignored --nocapture`: generating `fighter` (1.4M tets) in under 5 s in release mode.

#[test]
#[ignore = "timing: run in release with --ignored"]
fn fighter_generates_in_under_5_s() {
    let t = std::time::Instant::now();
    let m = datasets_gen::generate("fighter", None, 0).unwrap();
    let s = t.elapsed().as_secs_f64();
    println!(
        "fighter: {} tets, {} vertices in {s:.2} s ({} threads)",
        m.num_tets(),
        m.num_vertices(),
        rayon::current_num_threads()
    );
    assert!((m.num_tets() as f64 - 1.4e6).abs() <= 0.03 * 1.4e6);
    assert!(s < 5.0, "{s:.2} s");
}
