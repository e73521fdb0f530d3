//! Tetrahedral `.off`: a `nverts ntets` header, then `x y z s` per vertex, then `a b c d` per tet.
//!
//! Variants met in the wild are detected: a leading keyword line (`OFF`, `TOFF`, …) is skipped,
//! tet lines may carry a leading count `4`, `#` starts a comment. 1-based indices are refused
//! with a message unless `LoadOptions::one_based` is set. Vertex lines may lack the scalar (0).

use std::io::{BufRead, Read, Write};
use std::path::Path;

use glam::DVec3;

use super::{atomic_write, LoadOptions};
use crate::error::{Error, Result};
use crate::mesh::Mesh;

/// The longest line read: a vertex or tet line is well under 200 bytes, so a longer one is a
/// file that is not `.off` (and is refused before it fills memory).
const MAX_LINE: u64 = 1 << 20;

/// Reads a `.off` file line by line through a buffered reader, straight into the mesh's
/// arrays: the peak is the mesh and one line.
pub fn read_off(path: &Path, opts: &LoadOptions) -> Result<Mesh> {
    let f = super::open_input(path)?;
    let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
    let r = std::io::BufReader::with_capacity(1 << 16, f);
    parse_off_from(r, len, &path.display().to_string(), opts)
}

/// Parses `.off` text; `source` names it in messages.
pub fn parse_off(bytes: &[u8], source: &str, opts: &LoadOptions) -> Result<Mesh> {
    parse_off_from(bytes, bytes.len() as u64, source, opts)
}

/// The significant lines of a text stream (comments after `#` and blank lines left out), with
/// their 1-based line numbers, one at a time in one reused buffer.
struct Lines<'a, R> {
    r: R,
    buf: Vec<u8>,
    line: usize,
    source: &'a str,
}

impl<R: BufRead> Lines<'_, R> {
    fn next(&mut self) -> Result<Option<(usize, &str)>> {
        let (a, b) = loop {
            self.buf.clear();
            let n = (&mut self.r)
                .take(MAX_LINE + 1)
                .read_until(b'\n', &mut self.buf)
                .map_err(|e| Error::input(self.source, e))?;
            if n == 0 {
                return Ok(None);
            }
            self.line += 1;
            if n as u64 > MAX_LINE {
                return Err(Error::input(
                    format!("{}: line {}", self.source, self.line),
                    format!("longer than {MAX_LINE} bytes (not a .off file?)"),
                ));
            }
            let s = std::str::from_utf8(&self.buf).map_err(|e| {
                Error::input(
                    self.source,
                    format!("not a text file (line {}: {e})", self.line),
                )
            })?;
            // A UTF-8 byte-order mark is accepted (and ignored), as in every reader.
            let s = if self.line == 1 {
                s.strip_prefix('\u{feff}').unwrap_or(s)
            } else {
                s
            };
            let l = s.split('#').next().unwrap_or("").trim();
            if !l.is_empty() {
                let a = l.as_ptr() as usize - self.buf.as_ptr() as usize;
                break (a, a + l.len());
            }
        };
        // A slice of the line checked above, cut at character boundaries.
        Ok(Some((
            self.line,
            std::str::from_utf8(&self.buf[a..b]).unwrap_or(""),
        )))
    }
}

/// Up to `N` whitespace-separated words of `line` and how many it has (at most `N + 1`).
fn words<const N: usize>(line: &str) -> ([&str; N], usize) {
    let mut w = [""; N];
    let mut n = 0;
    for (i, x) in line.split_whitespace().enumerate() {
        if i == N {
            return (w, N + 1);
        }
        w[i] = x;
        n = i + 1;
    }
    (w, n)
}

/// Parses `.off` text from `r` (`len` bytes, which bounds what a lying header may reserve);
/// `source` names it in messages.
fn parse_off_from<R: BufRead>(r: R, len: u64, source: &str, opts: &LoadOptions) -> Result<Mesh> {
    let mut lines = Lines {
        r,
        buf: Vec::new(),
        line: 0,
        source,
    };
    let err = |line: usize, msg: String| Error::input(format!("{source}: line {line}"), msg);

    let (mut ln, first) = lines
        .next()?
        .ok_or_else(|| Error::input(source, "empty file"))?;
    let (w, n) = words::<3>(first);
    let first_is_keyword = n > 0 && w[0].chars().next().is_some_and(|c| c.is_ascii_alphabetic());
    let header: String = if first_is_keyword {
        if n >= 3 {
            first[first.find(char::is_whitespace).unwrap_or(0)..]
                .trim()
                .to_string()
        } else {
            let (l, h) = lines
                .next()?
                .ok_or_else(|| err(ln, "keyword line but no header follows".into()))?;
            ln = l;
            h.to_string()
        }
    } else {
        first.to_string()
    };
    let (counts, n) = words::<2>(&header);
    if n < 2 {
        return Err(err(
            ln,
            format!("expected 'nverts ntets', found '{header}'"),
        ));
    }
    let parse_count = |w: &str, what: &str| -> Result<usize> {
        w.parse::<usize>()
            .map_err(|_| err(ln, format!("{what} '{w}' is not a non-negative integer")))
    };
    let nv = parse_count(counts[0], "vertex count")?;
    let nt = parse_count(counts[1], "tet count")?;
    // A lying header must not make us allocate: a record takes at least 6 bytes of text.
    let cap = usize::try_from(len / 6).unwrap_or(usize::MAX);
    let mut pos = Vec::with_capacity(nv.min(cap));
    let mut scal = Vec::with_capacity(nv.min(cap));
    for k in 0..nv {
        let (l, line) = lines
            .next()?
            .ok_or_else(|| Error::input(source, format!("file ends after {k} of {nv} vertices")))?;
        let (w, n) = words::<4>(line);
        if n < 3 {
            return Err(err(
                l,
                format!("vertex {k}: expected 'x y z s', found '{line}'"),
            ));
        }
        let mut v = [0.0f64; 4];
        for (i, word) in w.iter().take(n.min(4)).enumerate() {
            v[i] = word
                .parse::<f64>()
                .map_err(|_| err(l, format!("vertex {k}: '{word}' is not a number")))?;
            if !v[i].is_finite() {
                return Err(err(l, format!("vertex {k}: non-finite value '{word}'")));
            }
        }
        pos.push(DVec3::new(v[0], v[1], v[2]));
        scal.push(v[3]);
    }
    let mut tets: Vec<[u32; 4]> = Vec::with_capacity(nt.min(cap));
    // What the index checks after the last tet need: the smallest and largest index, and the
    // first tet (number and line) with an index ≥ nv and with one > nv (out of range read
    // 0-based and 1-based).
    let (mut min, mut max) = (u32::MAX, 0u32);
    let (mut first_ge, mut first_gt) = (None, None);
    for k in 0..nt {
        let (l, line) = lines
            .next()?
            .ok_or_else(|| Error::input(source, format!("file ends after {k} of {nt} tets")))?;
        let (w, n) = words::<5>(line);
        let idx: &[&str] = match n {
            4 => &w[..4],
            5 if w[0] == "4" => &w[1..],
            _ => {
                return Err(err(
                    l,
                    format!("tet {k}: expected 'a b c d', found '{line}'"),
                ))
            }
        };
        let mut t = [0u32; 4];
        for (i, word) in idx.iter().enumerate() {
            t[i] = word.parse::<u32>().map_err(|_| {
                err(
                    l,
                    format!("tet {k}: '{word}' is not a non-negative vertex index"),
                )
            })?;
        }
        let (lo, hi) = (t.iter().min().copied(), t.iter().max().copied());
        let (lo, hi) = (lo.unwrap_or(0), hi.unwrap_or(0));
        (min, max) = (min.min(lo), max.max(hi));
        if hi as usize >= nv && first_ge.is_none() {
            first_ge = Some((k, l));
        }
        if hi as usize > nv && first_gt.is_none() {
            first_gt = Some((k, l));
        }
        tets.push(t);
    }
    let looks_one_based = nt > 0 && min >= 1 && max as usize == nv;
    if looks_one_based && !opts.one_based {
        return Err(Error::input(
            source,
            format!("indices are 1-based (they run 1..={nv}); pass --one-based to read it"),
        ));
    }
    let bad = if opts.one_based {
        if min == 0 {
            return Err(Error::input(
                source,
                "--one-based given but index 0 is used",
            ));
        }
        for t in &mut tets {
            for v in t.iter_mut() {
                *v -= 1;
            }
        }
        first_gt
    } else {
        first_ge
    };
    if let Some((k, l)) = bad {
        return Err(err(
            l,
            format!("tet {k}: index out of range {:?} (vertices: {nv})", tets[k]),
        ));
    }
    Mesh::with_scalars(source, pos, tets, "scalar", scal)
}

/// Writes the active field as `.off` with shortest round-trip number formatting (lossless).
pub fn write_off(mesh: &Mesh, path: &Path) -> Result<()> {
    atomic_write(path, |w| {
        writeln!(w, "{} {}", mesh.num_vertices(), mesh.num_tets())?;
        for (p, s) in mesh.positions().iter().zip(mesh.scalars()) {
            writeln!(w, "{:?} {:?} {:?} {:?}", p.x, p.y, p.z, s)?;
        }
        for t in mesh.tets() {
            writeln!(w, "{} {} {} {}", t[0], t[1], t[2], t[3])?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Mesh> {
        parse_off(s.as_bytes(), "t.off", &LoadOptions::default())
    }

    #[test]
    fn reads_plain_and_variants() {
        let m = parse("4 1\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n0 1 2 3\n").unwrap();
        assert_eq!(m.num_vertices(), 4);
        assert_eq!(m.tets(), &[[0, 1, 2, 3]]);
        assert_eq!(m.scalars(), &[1.0, 2.0, 3.0, 4.0]);
        let k = parse("OFF\n# c\n4 1 0\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n4 0 1 2 3\n").unwrap();
        assert_eq!(k.tets(), m.tets());
        let inline = parse("TOFF 4 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 1 2 3\n").unwrap();
        assert_eq!(inline.scalars(), &[0.0; 4]);
    }

    #[test]
    fn one_based_is_detected() {
        let text = "4 1\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n1 2 3 4\n";
        let e = parse(text).unwrap_err().to_string();
        assert!(e.contains("1-based"), "{e}");
        let opts = LoadOptions {
            one_based: true,
            ..Default::default()
        };
        let m = parse_off(text.as_bytes(), "t.off", &opts).unwrap();
        assert_eq!(m.tets(), &[[0, 1, 2, 3]]);
    }

    #[test]
    fn bad_input_names_file_and_line() {
        for (text, want) in [
            ("", "t.off: empty file"),
            ("4\n", "t.off: line 1: expected"),
            (
                "4 1\n0 0 0 1\n1 0 0 2\n",
                "t.off: file ends after 2 of 4 vertices",
            ),
            ("4 1\n0 0 0 1\n1 0 x 2\n", "t.off: line 3: vertex 1: 'x'"),
            (
                "4 1\n0 0 0 1\n1 0 nan 2\n",
                "t.off: line 3: vertex 1: non-finite",
            ),
            (
                "4 1\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n0 1 2 9\n",
                "t.off: line 6: tet 0: index out of range",
            ),
            (
                "4 1\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n0 1 -2 3\n",
                "t.off: line 6: tet 0",
            ),
            (
                "4 2\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n0 1 2 3\n",
                "t.off: file ends after 1 of 2 tets",
            ),
            (
                "99999999999 1\n",
                "file ends after 0 of 99999999999 vertices",
            ),
            ("-4 1\n", "not a non-negative integer"),
            ("4 0\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n", "no tetrahedra"),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
            assert!(!e.contains('\n'));
        }
    }

    #[test]
    fn write_read_round_trip_is_lossless() {
        let text =
            "4 1\n0.1 1e-300 -3.25 0.3333333333333333\n1e6 0 0 2\n0 1 0 3\n0 0 1 4\n0 1 2 3\n";
        let m = parse(text).unwrap();
        let dir = std::env::temp_dir().join(format!("tetbench-off-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("m.off");
        write_off(&m, &p).unwrap();
        let back = read_off(&p, &LoadOptions::default()).unwrap();
        assert_eq!(back.positions(), m.positions());
        assert_eq!(back.scalars(), m.scalars());
        assert_eq!(back.tets(), m.tets());
        std::fs::remove_dir_all(&dir).ok();
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            failure_persistence: None,
            ..Default::default() // 256 cases, or $PROPTEST_CASES
        })]
        /// Mutated and truncated files return an error or a mesh, never a panic.
        #[test]
        fn fuzz_never_panics(cut in 0usize..200, flips in proptest::collection::vec((0usize..200, 0u8..128), 0..6)) {
            let base = b"OFF\n5 2\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n1 1 1 5\n0 1 2 3\n1 2 3 4\n";
            let mut bytes = base.to_vec();
            for (at, b) in flips {
                let n = bytes.len();
                bytes[at % n] = b;
            }
            bytes.truncate(cut.min(bytes.len()));
            let _ = parse_off(&bytes, "f.off", &LoadOptions::default());
        }
    }
}
