//! The experiment TOML against hostile input: counts are bounded with a message naming the
//! key and the bound, and a proptest fuzzer checks that no text makes parsing and validation
//! panic or answer with more than one line. CI runs the default few hundred cases; a long run:
//! `PROPTEST_CASES=1000000 cargo test --release -p tetbench --test cli experiment_fuzz`.

use std::path::Path;

use proptest::prelude::*;
use tetbench::experiment;

fn check(text: &str) -> Result<(), String> {
    let cfg = experiment::parse(text, "fuzz.toml").map_err(|e| e.to_string())?;
    experiment::validate(cfg, Path::new("/nonexistent-tetbench-fuzz"))
        .map(|_| ())
        .map_err(|e| e.to_string())
}

const BASE: &str = "datasets = [\"spx:500\"]\nrenderers = [{ name = \"raycast\" }]\n";

#[test]
fn absurd_counts_are_refused_naming_key_and_bound() {
    for (extra, key) in [
        ("repeats = 123456789012", "repeats"),
        ("warmup = 1000000", "warmup"),
        ("[views]\nfibonacci = 1000000000", "views.fibonacci"),
        (
            "[views]\nrotate = { frames = 1000000000000 }",
            "views.rotate.frames",
        ),
    ] {
        let e = check(&format!("{BASE}{extra}\n")).unwrap_err();
        assert!(
            e.contains(&format!("`{key}`")) && e.contains("bound") && !e.contains('\n'),
            "{extra}: {e}"
        );
    }
    // Many sizes times many views: the matrix itself is bounded.
    let sizes: Vec<String> = (0..200).map(|i| format!("\"{}x8\"", i + 1)).collect();
    let e = check(&format!(
        "{BASE}sizes = [{}]\n[views]\nfibonacci = 9000\n",
        sizes.join(",")
    ))
    .unwrap_err();
    assert!(e.contains("bound"), "{e}");
}

fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<i64>().prop_map(|v| v.to_string()),
        (0u64..20).prop_map(|v| v.to_string()),
        any::<f64>().prop_map(|v| format!("{v:?}")),
        Just("true".to_string()),
        "[a-z0-9:,x\\-]{0,12}".prop_map(|s| format!("\"{s}\"")),
        prop::collection::vec("[a-z0-9:,x]{0,8}", 0..4).prop_map(|v| format!(
            "[{}]",
            v.iter()
                .map(|s| format!("\"{s}\""))
                .collect::<Vec<_>>()
                .join(",")
        )),
        Just("{ frames = 3, axis = \"y\" }".to_string()),
        Just("[{ name = \"raycast\", integrators = [\"partial\"] }]".to_string()),
    ]
}

fn key() -> impl Strategy<Value = &'static str> {
    prop::sample::select(vec![
        "name",
        "datasets",
        "renderers",
        "sizes",
        "projection",
        "tf",
        "repeats",
        "warmup",
        "error",
        "save_images",
        "seed",
        "cache_dir",
        "bogus",
    ])
}

proptest! {
    #[test]
    fn experiment_toml_never_panics(
        lines in prop::collection::vec((key(), value()), 0..8),
        views in prop::collection::vec((prop::sample::select(vec!["named", "fibonacci", "rotate", "x"]), value()), 0..3),
        cut in any::<prop::sample::Index>(),
        junk in "[\\[\\]{}=\",#\n a-z0-9.\u{feff}]{0,6}",
    ) {
        let mut text = String::new();
        for (k, v) in &lines {
            text.push_str(&format!("{k} = {v}\n"));
        }
        if !views.is_empty() {
            text.push_str("[views]\n");
            for (k, v) in &views {
                text.push_str(&format!("{k} = {v}\n"));
            }
        }
        // Splice junk somewhere (on a char boundary).
        let mut at = cut.index(text.len() + 1);
        while !text.is_char_boundary(at) {
            at -= 1;
        }
        text.insert_str(at, &junk);
        if let Err(e) = check(&text) {
            prop_assert!(!e.contains('\n'), "two lines for {:?}: {}", text, e);
        }
    }
}
