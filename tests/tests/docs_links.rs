//! The docs' references resolve: every relative link in `README.md` and `docs/` names a file
//! (and, with `#anchor`, a heading) that exists; every repository path written as inline code
//! there names a file or folder that exists; every `docs/*.md` that a source file names
//! exists; and every contract section cited (`CONVENTIONS §N` anywhere, a bare `§N` in the
//! docs) is a numbered heading `## N.` of `docs/contract.md`. Section signs after a paper's name
//! (`PTINT §3`, `BCC §4`) cite the paper and are left alone.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate sits in the workspace")
        .to_path_buf()
}

/// Files under `dir` (recursively) whose name ends with one of `exts`, skipping build output
/// and hidden folders.
fn files(dir: &Path, exts: &[&str], out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if p.is_dir() {
            if name != "target" && !name.starts_with('.') {
                files(&p, exts, out);
            }
        } else if exts.iter().any(|x| name.ends_with(x)) {
            out.push(p);
        }
    }
}

fn markdown_docs() -> Vec<PathBuf> {
    let mut v = vec![root().join("README.md")];
    files(&root().join("docs"), &[".md"], &mut v);
    v
}

/// The text outside fenced code blocks, line by line (1-based line numbers).
fn prose(text: &str) -> Vec<(usize, &str)> {
    let mut fenced = false;
    let mut v = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced {
            v.push((i + 1, line));
        }
    }
    v
}

/// GitHub's anchor of a heading: lower case, spaces to `-`, punctuation other than `-` and
/// `_` dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    for (_, line) in prose(text) {
        let t = line.trim_start();
        if t.starts_with('#') {
            let base = slug(t.trim_start_matches('#'));
            let mut a = base.clone();
            let mut n = 1;
            while seen.contains(&a) {
                a = format!("{base}-{n}");
                n += 1;
            }
            seen.insert(a);
        }
    }
    seen
}

/// The targets of inline links `[text](target)` on a line.
fn link_targets(line: &str) -> Vec<String> {
    let mut v = Vec::new();
    let mut rest = line;
    while let Some(i) = rest.find("](") {
        let after = &rest[i + 2..];
        match after.find(')') {
            Some(j) => {
                let t = after[..j].split_whitespace().next().unwrap_or("");
                v.push(t.to_string());
                rest = &after[j..];
            }
            None => break,
        }
    }
    v
}

/// The inline code spans of a line.
fn code_spans(line: &str) -> Vec<&str> {
    line.split('`').skip(1).step_by(2).collect()
}

/// The section numbers cited as `§N` on a line, with the text just before each sign.
fn sections(line: &str) -> Vec<(u32, String)> {
    let mut v = Vec::new();
    for (i, _) in line.match_indices('§') {
        let after = line[i + '§'.len_utf8()..].trim_start();
        let digits: String = after.chars().take_while(char::is_ascii_digit).collect();
        if let Ok(n) = digits.parse() {
            let before: String = line[..i]
                .chars()
                .rev()
                .take(16)
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect();
            v.push((n, before));
        }
    }
    v
}

/// A `§` that follows the name of a paper cites the paper, not the contract.
fn cites_a_paper(before: &str) -> bool {
    ["PTINT", "HAPT", "BCC", "JBU", "paper"]
        .iter()
        .any(|p| before.contains(p))
}

fn contract_sections() -> BTreeSet<u32> {
    let text = std::fs::read_to_string(root().join("docs/contract.md")).unwrap();
    prose(&text)
        .into_iter()
        .filter_map(|(_, l)| {
            let n: String = l
                .strip_prefix("## ")?
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            l.strip_prefix("## ")?
                .strip_prefix(n.as_str())?
                .starts_with('.')
                .then_some(())?;
            n.parse().ok()
        })
        .collect()
}

fn rel(p: &Path) -> String {
    p.strip_prefix(root()).unwrap_or(p).display().to_string()
}

#[test]
fn contract_numbers_sections_one_to_nine() {
    assert_eq!(contract_sections(), (1..=9).collect::<BTreeSet<u32>>());
}

#[test]
fn relative_links_in_readme_and_docs_resolve() {
    let mut bad = Vec::new();
    for doc in markdown_docs() {
        let text = std::fs::read_to_string(&doc).unwrap();
        let dir = doc.parent().unwrap();
        for (n, line) in prose(&text) {
            for t in link_targets(line) {
                if t.is_empty() || t.contains("://") || t.starts_with("mailto:") {
                    continue;
                }
                let (path, anchor) = match t.split_once('#') {
                    Some((p, a)) => (p, Some(a)),
                    None => (t.as_str(), None),
                };
                let target = if path.is_empty() {
                    doc.clone()
                } else {
                    dir.join(path)
                };
                if !target.exists() {
                    bad.push(format!("{}:{n}: `{t}`: no such file", rel(&doc)));
                    continue;
                }
                if let Some(a) = anchor {
                    let body = std::fs::read_to_string(&target).unwrap_or_default();
                    if !anchors(&body).contains(a) {
                        bad.push(format!(
                            "{}:{n}: `{t}`: no heading with that anchor",
                            rel(&doc)
                        ));
                    }
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "links that do not resolve:\n{}",
        bad.join("\n")
    );
}

#[test]
fn repository_paths_named_in_the_docs_exist() {
    const TOP: [&str; 5] = ["algorithms/", "harness/", "datasets-gen/", "tests/", ".ci/"];
    let mut bad = Vec::new();
    for doc in markdown_docs() {
        let text = std::fs::read_to_string(&doc).unwrap();
        for (n, line) in prose(&text) {
            for span in code_spans(line) {
                let is_path = TOP.iter().any(|t| span.starts_with(t))
                    && !span.contains(['<', '*', ' ', '…', '|', '{']);
                if is_path && !root().join(span).exists() {
                    bad.push(format!("{}:{n}: `{span}`", rel(&doc)));
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "paths in the docs that do not exist:\n{}",
        bad.join("\n")
    );
}

#[test]
fn docs_named_in_the_sources_exist() {
    let mut sources = Vec::new();
    for d in ["algorithms", "harness", "datasets-gen", "tests", ".ci"] {
        files(
            &root().join(d),
            &[".rs", ".wgsl", ".py", ".toml", ".sh", "run"],
            &mut sources,
        );
    }
    let mut bad = Vec::new();
    for src in sources {
        let Ok(text) = std::fs::read_to_string(&src) else {
            continue;
        };
        for (n, line) in text.lines().enumerate() {
            for (i, _) in line.match_indices("docs/") {
                let name: String = line[i..]
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || "/_-.".contains(*c))
                    .collect();
                let name = name.trim_end_matches('.');
                if name.ends_with(".md") && !root().join(name).exists() {
                    bad.push(format!("{}:{}: {name}", rel(&src), n + 1));
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "docs named in the sources that do not exist:\n{}",
        bad.join("\n")
    );
}

#[test]
fn cited_contract_sections_exist() {
    let have = contract_sections();
    let mut bad = Vec::new();
    for doc in markdown_docs() {
        let text = std::fs::read_to_string(&doc).unwrap();
        for (n, line) in prose(&text) {
            for (s, before) in sections(line) {
                if !cites_a_paper(&before) && !have.contains(&s) {
                    bad.push(format!("{}:{n}: §{s}", rel(&doc)));
                }
            }
        }
    }
    let mut sources = Vec::new();
    for d in ["algorithms", "harness", "datasets-gen", "tests"] {
        files(
            &root().join(d),
            &[".rs", ".wgsl", ".py", ".toml"],
            &mut sources,
        );
    }
    for src in sources {
        let text = std::fs::read_to_string(&src).unwrap_or_default();
        for (n, line) in text.lines().enumerate() {
            for (s, before) in sections(line) {
                if before.contains("CONVENTIONS") && !have.contains(&s) {
                    bad.push(format!("{}:{}: CONVENTIONS §{s}", rel(&src), n + 1));
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "cited sections missing from docs/contract.md:\n{}",
        bad.join("\n")
    );
}

#[test]
fn the_checker_sees_links_paths_and_sections() {
    assert_eq!(
        link_targets("see [a](b.md#c) and [d](e/)"),
        ["b.md#c", "e/"]
    );
    assert_eq!(
        code_spans("run `x` then `harness/src`"),
        ["x", "harness/src"]
    );
    assert_eq!(
        slug(" 4. Optical model and integrators"),
        "4-optical-model-and-integrators"
    );
    assert_eq!(
        slug("The wrapper: `jbu:<renderer>@<size>`"),
        "the-wrapper-jburenderersize"
    );
    let s = sections("CONVENTIONS §6 and PTINT §3");
    assert_eq!(s.iter().map(|x| x.0).collect::<Vec<_>>(), [6, 3]);
    assert!(!cites_a_paper(&s[0].1) && cites_a_paper(&s[1].1));
    assert_eq!(prose("a\n```\n[x](nope)\n```\nb").len(), 2);
}
