//! VTK legacy `.vtk` reader: ASCII and BINARY (big-endian), `UNSTRUCTURED_GRID` with both
//! `CELLS` layouts (4.2 `k i0 … ik` records; 5.1 `OFFSETS`/`CONNECTIVITY` arrays) and
//! `STRUCTURED_GRID` (split into tets as asked), point `SCALARS` and `FIELD` arrays as named
//! fields; `VECTORS`, `NORMALS`, `CELL_DATA`, `METADATA` and the like are skipped.
//!
//! Hand-written rather than on the `vtkio` crate: vtkio is not among the crates this workspace
//! keeps (nor in the registry cache here), and what is needed is a reader we control: every
//! count checked against the bytes left before anything is allocated (fuzzed), both `CELLS`
//! layouts (the 5.1 one is recognised by its `OFFSETS` line), and one-line errors that name the
//! file, the line and the section. It is ~500 lines.

use std::collections::BTreeMap;
use std::fmt::Display;
use std::path::Path;

use glam::DVec3;

use crate::error::{Error, Result};
use crate::io::split::{self, DType};
use crate::io::LoadOptions;
use crate::mesh::Mesh;

/// An array name with VTK's `%XX` escapes (spaces and other bytes a legacy name cannot hold)
/// decoded; a `%` not followed by two hex digits stays as it is.
fn decode_name(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match (
            b[i],
            b.get(i + 1).and_then(|&c| hex(c)),
            b.get(i + 2).and_then(|&c| hex(c)),
        ) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Reads a VTK legacy file (see the module docs).
pub fn read_vtk(path: &Path, opts: &LoadOptions) -> Result<Mesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_vtk(&bytes, &path.display().to_string(), opts)
}

/// What a data array holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ty {
    Num(DType),
    Bit,
    Str,
}

struct Cur<'a> {
    b: &'a [u8],
    pos: usize,
    line: usize,
    src: &'a str,
    binary: bool,
    /// The line terminator: `\n` (with or without `\r` before it), or `\r` for a file with
    /// CR-only line endings (classic Mac), detected from the first line.
    eol: u8,
}

impl<'a> Cur<'a> {
    fn err(&self, line: usize, msg: impl Display) -> Error {
        Error::input(format!("{}:{line}", self.src), msg)
    }

    fn remaining(&self) -> usize {
        self.b.len() - self.pos
    }

    fn skip_ws(&mut self) {
        while self.pos < self.b.len() && self.b[self.pos].is_ascii_whitespace() {
            if self.b[self.pos] == self.eol {
                self.line += 1;
            }
            self.pos += 1;
        }
    }

    /// The rest of the current line (without `\r\n`), and its line number.
    fn raw_line(&mut self) -> Option<(usize, &'a [u8])> {
        if self.pos >= self.b.len() {
            return None;
        }
        let start = self.pos;
        let l = self.line;
        let eol = self.eol;
        let end = match self.b[start..].iter().position(|&c| c == eol) {
            Some(i) => {
                self.pos = start + i + 1;
                self.line += 1;
                start + i
            }
            None => {
                self.pos = self.b.len();
                self.b.len()
            }
        };
        let mut s = &self.b[start..end];
        if s.last() == Some(&b'\r') {
            s = &s[..s.len() - 1];
        }
        Some((l, s))
    }

    /// The next non-blank line, split into words.
    fn keyword_line(&mut self) -> Result<Option<(usize, Vec<&'a str>)>> {
        self.skip_ws();
        let Some((l, s)) = self.raw_line() else {
            return Ok(None);
        };
        let s = std::str::from_utf8(s)
            .map_err(|_| self.err(l, "expected a keyword line, found binary data"))?;
        Ok(Some((l, s.split_whitespace().collect())))
    }

    /// The next word, upper-cased, without consuming anything.
    fn peek_word(&self) -> String {
        let mut p = self.pos;
        while p < self.b.len() && self.b[p].is_ascii_whitespace() {
            p += 1;
        }
        let s = p;
        while p < self.b.len() && !self.b[p].is_ascii_whitespace() && p - s < 32 {
            p += 1;
        }
        String::from_utf8_lossy(&self.b[s..p]).to_ascii_uppercase()
    }

    fn token(&mut self) -> Option<&'a [u8]> {
        self.skip_ws();
        let s = self.pos;
        while self.pos < self.b.len() && !self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (self.pos > s).then(|| &self.b[s..self.pos])
    }

    /// Refuses `n` values that the rest of the file could not hold, before anything is
    /// allocated for them; returns the byte count for binary data.
    fn check_room(&self, n: usize, ty: Ty, what: &str, line: usize) -> Result<usize> {
        let rem = self.remaining();
        if self.binary {
            let bytes = match ty {
                Ty::Num(d) => n.checked_mul(d.size()),
                Ty::Bit => Some(n.div_ceil(8)),
                Ty::Str => Some(n), // at least a newline each
            };
            match bytes {
                Some(b) if b <= rem => Ok(b),
                _ => Err(self.err(
                    line,
                    format!("{what}: {n} values announced but only {rem} bytes remain (truncated file or wrong count)"),
                )),
            }
        } else if n > rem / 2 + 1 {
            Err(self.err(
                line,
                format!("{what}: {n} values announced but only {rem} bytes remain (truncated file or wrong count)"),
            ))
        } else {
            Ok(0)
        }
    }

    fn ascii_tokens<T>(
        &mut self,
        n: usize,
        what: &str,
        mut parse: impl FnMut(&str) -> Option<T>,
    ) -> Result<Vec<T>> {
        let mut out = Vec::with_capacity(n);
        for k in 0..n {
            let Some(t) = self.token() else {
                return Err(self.err(
                    self.line,
                    format!("{what}: file ends after {k} of {n} values"),
                ));
            };
            let v = std::str::from_utf8(t).ok().and_then(&mut parse);
            match v {
                Some(v) => out.push(v),
                None => {
                    return Err(self.err(
                        self.line,
                        format!(
                            "{what}: '{}' is not a valid value",
                            String::from_utf8_lossy(&t[..t.len().min(40)]).escape_debug()
                        ),
                    ))
                }
            }
        }
        Ok(out)
    }

    fn values(&mut self, n: usize, ty: DType, what: &str, line: usize) -> Result<Vec<f64>> {
        let bytes = self.check_room(n, Ty::Num(ty), what, line)?;
        if self.binary {
            let v = split::decode_f64(&self.b[self.pos..self.pos + bytes], ty, true);
            self.advance_binary(bytes);
            Ok(v)
        } else {
            self.ascii_tokens(n, what, |s| s.parse::<f64>().ok())
        }
    }

    fn ints(&mut self, n: usize, ty: DType, what: &str, line: usize) -> Result<Vec<i64>> {
        let bytes = self.check_room(n, Ty::Num(ty), what, line)?;
        if self.binary {
            let v = split::decode_i64(&self.b[self.pos..self.pos + bytes], ty, true)
                .map_err(|m| self.err(line, format!("{what}: {m}")))?;
            self.advance_binary(bytes);
            Ok(v)
        } else {
            self.ascii_tokens(n, what, |s| s.parse::<i64>().ok())
        }
    }

    fn skip(&mut self, n: usize, ty: Ty, what: &str, line: usize) -> Result<()> {
        let bytes = self.check_room(n, ty, what, line)?;
        if !self.binary {
            self.ascii_tokens(n, what, |_| Some(()))?;
        } else if ty == Ty::Str {
            for k in 0..n {
                if self.raw_line().is_none() {
                    return Err(
                        self.err(line, format!("{what}: file ends after {k} of {n} strings"))
                    );
                }
            }
        } else {
            self.advance_binary(bytes);
        }
        Ok(())
    }

    fn advance_binary(&mut self, bytes: usize) {
        let end = self.pos + bytes;
        self.line += self.b[self.pos..end]
            .iter()
            .filter(|&&c| c == self.eol)
            .count();
        self.pos = end;
    }

    /// Skips a `METADATA` block (up to its blank line) if one follows.
    fn metadata(&mut self) -> Result<()> {
        if self.peek_word() == "METADATA" {
            self.keyword_line()?;
            while let Some((_, s)) = self.raw_line() {
                if s.iter().all(|c| c.is_ascii_whitespace()) {
                    break;
                }
            }
        }
        Ok(())
    }
}

fn count(c: &Cur, line: usize, w: &[&str], i: usize) -> Result<usize> {
    let kw = w[0];
    let Some(s) = w.get(i) else {
        return Err(c.err(line, format!("{kw}: missing count")));
    };
    match s.parse::<i64>() {
        Ok(v) if v >= 0 => {
            usize::try_from(v).map_err(|_| c.err(line, format!("{kw}: count {v} too large")))
        }
        Ok(v) => Err(c.err(line, format!("{kw}: negative count {v}"))),
        Err(_) => Err(c.err(line, format!("{kw}: '{}' is not a count", s.escape_debug()))),
    }
}

fn ty_of(c: &Cur, line: usize, kw: &str, s: Option<&&str>) -> Result<Ty> {
    let Some(s) = s else {
        return Err(c.err(line, format!("{kw}: missing data type")));
    };
    match s.to_ascii_lowercase().as_str() {
        "bit" => Ok(Ty::Bit),
        "string" | "utf8_string" => Ok(Ty::Str),
        _ => DType::from_legacy(s).map(Ty::Num).ok_or_else(|| {
            c.err(
                line,
                format!("{kw}: unknown data type '{}'", s.escape_debug()),
            )
        }),
    }
}

fn num_ty(c: &Cur, line: usize, kw: &str, s: Option<&&str>) -> Result<DType> {
    match ty_of(c, line, kw, s)? {
        Ty::Num(d) => Ok(d),
        _ => Err(c.err(line, format!("{kw}: a numeric data type is needed"))),
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    None,
    Point(usize),
    Cell(usize),
}

/// Parses a VTK legacy file held in memory; `source` names it in messages.
pub fn parse_vtk(bytes: &[u8], source: &str, opts: &LoadOptions) -> Result<Mesh> {
    // A UTF-8 byte-order mark is accepted (and ignored), as in every reader.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    // CR-only line endings: the first line ends in a lone '\r'.
    let eol = match bytes.iter().position(|&c| c == b'\n' || c == b'\r') {
        Some(i) if bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n') => b'\r',
        _ => b'\n',
    };
    let mut c = Cur {
        b: bytes,
        pos: 0,
        line: 1,
        src: source,
        binary: false,
        eol,
    };
    let header = c
        .raw_line()
        .map(|(_, s)| String::from_utf8_lossy(s).to_ascii_lowercase());
    let header = header.unwrap_or_default();
    if !header.trim().starts_with("# vtk datafile version") {
        return Err(c.err(
            1,
            "not a VTK legacy file (expected '# vtk DataFile Version X.Y')",
        ));
    };
    if c.raw_line().is_none() {
        return Err(c.err(2, "file ends before the title line"));
    }
    let Some((l, w)) = c.keyword_line()? else {
        return Err(c.err(c.line, "file ends before ASCII/BINARY"));
    };
    c.binary = match w.first().map(|s| s.to_ascii_uppercase()).as_deref() {
        Some("ASCII") => false,
        Some("BINARY") => true,
        _ => return Err(c.err(l, "expected ASCII or BINARY")),
    };
    let Some((l, w)) = c.keyword_line()? else {
        return Err(c.err(c.line, "file ends before DATASET"));
    };
    if w.len() < 2 || !w[0].eq_ignore_ascii_case("DATASET") {
        return Err(c.err(
            l,
            "expected 'DATASET UNSTRUCTURED_GRID' or 'DATASET STRUCTURED_GRID'",
        ));
    }
    let structured = match w[1].to_ascii_uppercase().as_str() {
        "UNSTRUCTURED_GRID" => false,
        "STRUCTURED_GRID" => true,
        other => {
            return Err(c.err(
                l,
                format!("DATASET {other} is not read (only UNSTRUCTURED_GRID and STRUCTURED_GRID)"),
            ))
        }
    };

    let mut points: Option<(usize, Vec<f64>)> = None;
    let mut dims: Option<(usize, [usize; 3])> = None;
    let mut cells: Option<(usize, Vec<usize>, Vec<i64>)> = None;
    let mut types: Option<(usize, Vec<u8>)> = None;
    let mut arrays: Vec<(String, Vec<f64>)> = Vec::new();
    let mut point_data_line: Option<(usize, usize)> = None;
    let mut first_scalars: Option<String> = None;
    let mut field_data: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut mode = Mode::None;

    while let Some((l, w)) = c.keyword_line()? {
        if w.is_empty() {
            continue;
        }
        let kw = w[0].to_ascii_uppercase();
        match kw.as_str() {
            "POINTS" => {
                if points.is_some() {
                    return Err(c.err(l, "a second POINTS section"));
                }
                let n = count(&c, l, &w, 1)?;
                let ty = num_ty(&c, l, "POINTS", w.get(2))?;
                let n3 = n
                    .checked_mul(3)
                    .ok_or_else(|| c.err(l, "POINTS: count too large"))?;
                let v = c.values(n3, ty, "POINTS", l)?;
                points = Some((l, v));
                c.metadata()?;
            }
            "DIMENSIONS" => {
                let d = [
                    count(&c, l, &w, 1)?,
                    count(&c, l, &w, 2)?,
                    count(&c, l, &w, 3)?,
                ];
                dims = Some((l, d));
            }
            "CELLS" => {
                if cells.is_some() {
                    return Err(c.err(l, "a second CELLS section"));
                }
                let a = count(&c, l, &w, 1)?;
                let b = count(&c, l, &w, 2)?;
                if c.peek_word() == "OFFSETS" {
                    // 5.1: a = cells + 1 offsets, b = connectivity entries.
                    let (l2, w2) = c.keyword_line()?.unwrap_or_default();
                    let ty = num_ty(&c, l2, "OFFSETS", w2.get(1))?;
                    let offs = c.ints(a, ty, "OFFSETS", l2)?;
                    c.metadata()?;
                    let Some((l3, w3)) = c.keyword_line()? else {
                        return Err(c.err(c.line, "CELLS: file ends before CONNECTIVITY"));
                    };
                    if !w3
                        .first()
                        .is_some_and(|s| s.eq_ignore_ascii_case("CONNECTIVITY"))
                    {
                        return Err(c.err(l3, "CELLS: expected CONNECTIVITY after OFFSETS"));
                    }
                    let ty = num_ty(&c, l3, "CONNECTIVITY", w3.get(1))?;
                    let conn = c.ints(b, ty, "CONNECTIVITY", l3)?;
                    c.metadata()?;
                    let offsets = match offs.split_first() {
                        None => vec![0],
                        Some((&first, rest)) => {
                            if first != 0 {
                                return Err(
                                    c.err(l2, format!("OFFSETS: first offset is {first}, not 0"))
                                );
                            }
                            if rest.last().is_some_and(|&e| e != b as i64) {
                                return Err(c.err(
                                    l2,
                                    format!("OFFSETS: last offset {} differs from the {b} CONNECTIVITY entries", rest[rest.len() - 1]),
                                ));
                            }
                            split::offsets_from_ends(
                                &format!("{source}:{l2}"),
                                "OFFSETS",
                                rest,
                                conn.len(),
                            )?
                        }
                    };
                    cells = Some((l, offsets, conn));
                } else {
                    // 4.2: a cells, b integers in `k i0 … ik` records.
                    let raw = c.ints(b, DType::I32, "CELLS", l)?;
                    if a > raw.len() {
                        return Err(c.err(
                            l,
                            format!("CELLS: {a} cells cannot fit in {} integers", raw.len()),
                        ));
                    }
                    let mut offsets = Vec::with_capacity(a + 1);
                    let mut conn = Vec::with_capacity(raw.len() - a);
                    offsets.push(0);
                    let mut i = 0usize;
                    for cell in 0..a {
                        let Some(&k) = raw.get(i) else {
                            return Err(c.err(
                                l,
                                format!("CELLS: the {b} integers hold only {cell} of the {a} cell records"),
                            ));
                        };
                        if k < 0 || (k as u64) >= (raw.len() - i) as u64 {
                            return Err(c.err(
                                l,
                                format!("CELLS: record of cell {cell} (size {k}) runs past the {b} integers announced"),
                            ));
                        }
                        conn.extend_from_slice(&raw[i + 1..i + 1 + k as usize]);
                        offsets.push(conn.len());
                        i += 1 + k as usize;
                    }
                    if i != raw.len() {
                        return Err(c.err(
                            l,
                            format!("CELLS: the {a} cell records use {i} integers, not the {b} announced"),
                        ));
                    }
                    cells = Some((l, offsets, conn));
                }
            }
            "CELL_TYPES" => {
                let n = count(&c, l, &w, 1)?;
                let v = c.ints(n, DType::I32, "CELL_TYPES", l)?;
                let mut t = Vec::with_capacity(v.len());
                for (i, &x) in v.iter().enumerate() {
                    match u8::try_from(x) {
                        Ok(x) => t.push(x),
                        Err(_) => {
                            return Err(c.err(
                                l,
                                format!(
                                    "CELL_TYPES: cell {i} has unknown VTK type {x} ({})",
                                    split::cell_type_name(x)
                                ),
                            ))
                        }
                    }
                }
                types = Some((l, t));
                c.metadata()?;
            }
            "POINT_DATA" => {
                let n = count(&c, l, &w, 1)?;
                mode = Mode::Point(n);
                point_data_line = Some((l, n));
            }
            "CELL_DATA" => mode = Mode::Cell(count(&c, l, &w, 1)?),
            "METADATA" => {
                // A block after a section we have already read: skip to its blank line.
                while let Some((_, s)) = c.raw_line() {
                    if s.iter().all(|b| b.is_ascii_whitespace()) {
                        break;
                    }
                }
            }
            "FIELD" => {
                let narr = count(&c, l, &w, 2)?;
                for _ in 0..narr {
                    let Some((la, wa)) = c.keyword_line()? else {
                        return Err(c.err(c.line, "FIELD: file ends before all its arrays"));
                    };
                    if wa.first() == Some(&"NULL_ARRAY") {
                        continue;
                    }
                    if wa.len() < 4 {
                        return Err(
                            c.err(la, "FIELD array: expected 'name components tuples type'")
                        );
                    }
                    let name = decode_name(wa[0]);
                    let what = format!("FIELD array '{}'", name.escape_debug());
                    let ncomp = count(&c, la, &wa, 1)?;
                    let ntup = count(&c, la, &wa, 2)?;
                    let ty = ty_of(&c, la, &what, wa.get(3))?;
                    let n = ncomp
                        .checked_mul(ntup)
                        .ok_or_else(|| c.err(la, format!("{what}: size too large")))?;
                    match (mode, ty) {
                        (Mode::None, Ty::Num(d)) => {
                            field_data.insert(name, c.values(n, d, &what, la)?);
                        }
                        (Mode::Point(np), Ty::Num(d)) if ncomp == 1 && ntup == np => {
                            arrays.push((name, c.values(n, d, &what, la)?));
                        }
                        (Mode::Point(np), _) if ntup != np => {
                            return Err(c.err(la, format!("{what}: {ntup} tuples for {np} points")));
                        }
                        _ => c.skip(n, ty, &what, la)?,
                    }
                    c.metadata()?;
                }
            }
            "SCALARS"
            | "LOOKUP_TABLE"
            | "COLOR_SCALARS"
            | "VECTORS"
            | "NORMALS"
            | "TEXTURE_COORDINATES"
            | "TENSORS"
            | "TENSORS6"
            | "GLOBAL_IDS"
            | "PEDIGREE_IDS"
            | "EDGE_FLAGS" => {
                let n = match mode {
                    Mode::Point(n) | Mode::Cell(n) => n,
                    Mode::None => {
                        return Err(c.err(l, format!("{kw} before POINT_DATA or CELL_DATA")));
                    }
                };
                let name = decode_name(w.get(1).copied().unwrap_or(""));
                let name = name.as_str();
                let what = format!("{kw} '{}'", name.escape_debug());
                let too_large =
                    || Error::input(format!("{source}:{l}"), format!("{what}: size too large"));
                let mul = |k: usize| n.checked_mul(k).ok_or_else(too_large);
                match kw.as_str() {
                    "SCALARS" => {
                        let ty = ty_of(&c, l, &what, w.get(2))?;
                        let ncomp = match w.get(3) {
                            None => 1,
                            Some(_) => count(&c, l, &w, 3)?,
                        };
                        if !(1..=4).contains(&ncomp) {
                            return Err(
                                c.err(l, format!("{what}: {ncomp} components (1 to 4 allowed)"))
                            );
                        }
                        if c.peek_word() == "LOOKUP_TABLE" {
                            c.keyword_line()?;
                        }
                        match (mode, ty) {
                            (Mode::Point(_), Ty::Num(d)) if ncomp == 1 => {
                                arrays.push((name.to_string(), c.values(n, d, &what, l)?));
                                first_scalars.get_or_insert_with(|| name.to_string());
                            }
                            _ => c.skip(mul(ncomp)?, ty, &what, l)?,
                        }
                    }
                    "LOOKUP_TABLE" => {
                        let size = count(&c, l, &w, 2)?;
                        let m = size
                            .checked_mul(4)
                            .ok_or_else(|| c.err(l, format!("{what}: size too large")))?;
                        let ty = if c.binary { DType::U8 } else { DType::F32 };
                        c.skip(m, Ty::Num(ty), &what, l)?;
                    }
                    "COLOR_SCALARS" => {
                        let k = count(&c, l, &w, 2)?;
                        let ty = if c.binary { DType::U8 } else { DType::F32 };
                        c.skip(mul(k)?, Ty::Num(ty), &what, l)?;
                    }
                    "TEXTURE_COORDINATES" => {
                        let k = count(&c, l, &w, 2)?;
                        let ty = ty_of(&c, l, &what, w.get(3))?;
                        c.skip(mul(k)?, ty, &what, l)?;
                    }
                    _ => {
                        let k = match kw.as_str() {
                            "VECTORS" | "NORMALS" => 3,
                            "TENSORS" => 9,
                            "TENSORS6" => 6,
                            _ => 1,
                        };
                        let ty = ty_of(&c, l, &what, w.get(2))?;
                        c.skip(mul(k)?, ty, &what, l)?;
                    }
                }
                c.metadata()?;
            }
            _ => {
                return Err(c.err(
                    l,
                    format!(
                        "unknown keyword '{}'",
                        w[0].chars().take(40).collect::<String>().escape_debug()
                    ),
                ))
            }
        }
    }

    let Some((pl, xyz)) = points else {
        return Err(Error::input(source, "no POINTS section"));
    };
    let mut positions: Vec<DVec3> = xyz
        .chunks_exact(3)
        .map(|p| DVec3::new(p[0], p[1], p[2]))
        .collect();
    let npts = positions.len();
    if let Some((l, n)) = point_data_line {
        if n != npts {
            return Err(c.err(
                l,
                format!("POINT_DATA {n} differs from the {npts} POINTS (line {pl})"),
            ));
        }
    }
    if arrays.is_empty() {
        return Err(Error::input(
            source,
            "no point scalars (a POINT_DATA section with SCALARS or FIELD arrays)",
        ));
    }
    let (names, mut values): (Vec<String>, Vec<Vec<f64>>) = arrays.into_iter().unzip();
    let tets = if structured {
        let Some((dl, d)) = dims else {
            return Err(Error::input(source, "STRUCTURED_GRID without DIMENSIONS"));
        };
        if d.iter().try_fold(1usize, |a, &x| a.checked_mul(x)) != Some(npts) {
            return Err(c.err(
                dl,
                format!(
                    "DIMENSIONS {}×{}×{} do not match the {npts} POINTS",
                    d[0], d[1], d[2]
                ),
            ));
        }
        let Some(s) = opts.split else {
            return Err(Error::input(
                source,
                "a STRUCTURED_GRID is made of hexahedra; ask for a split (--split 5 or 6) to read it as tetrahedra",
            ));
        };
        split::split_structured(source, d, &positions, s)?
    } else {
        let Some((cl, offsets, conn)) = cells else {
            return Err(Error::input(source, "no CELLS section"));
        };
        let Some((tl, types)) = types else {
            return Err(Error::input(source, "no CELL_TYPES section"));
        };
        if types.len() + 1 != offsets.len() {
            return Err(c.err(
                tl,
                format!(
                    "CELL_TYPES has {} entries for {} CELLS (line {cl})",
                    types.len(),
                    offsets.len() - 1
                ),
            ));
        }
        split::split_cells(
            source,
            &types,
            &offsets,
            &conn,
            &mut positions,
            &mut values,
            opts.split,
        )?
    };
    let fields = split::make_fields(names.into_iter().zip(values).collect());
    let mut mesh = Mesh::new(source, positions, tets, fields)?;
    mesh.field_data = field_data;
    split::select_active(
        &mut mesh,
        source,
        opts.scalar.as_deref(),
        first_scalars.as_deref(),
    )?;
    Ok(mesh)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::io::Split;

    pub(crate) const ASCII_42: &str = "# vtk DataFile Version 4.2
two tets
ASCII
DATASET UNSTRUCTURED_GRID
FIELD FieldData 1
TIME 1 1 double
2.5
POINTS 5 float
0 0 0  1 0 0  0 1 0
0 0 1  1 1 1
CELLS 2 10
4 0 1 2 3
4 1 2 3 4
CELL_TYPES 2
10
10
CELL_DATA 2
SCALARS id int 1
LOOKUP_TABLE default
0 1
POINT_DATA 5
VECTORS v float
0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
SCALARS temp float
LOOKUP_TABLE default
0 1 2 3 4
FIELD f 2
pressure 1 5 double
10 11 12 13 14
vel 3 5 float
0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
";

    pub(crate) const ASCII_51: &str = "# vtk DataFile Version 5.1
two tets
ASCII
DATASET UNSTRUCTURED_GRID
POINTS 5 double
0 0 0 1 0 0 0 1 0 0 0 1 1 1 1
METADATA
INFORMATION 0

CELLS 3 8
OFFSETS vtktypeint64
0 4 8
CONNECTIVITY vtktypeint64
0 1 2 3
1 2 3 4
CELL_TYPES 2
10
10
POINT_DATA 5
SCALARS temp double 1
0 1 2 3 4
SCALARS pressure int
LOOKUP_TABLE default
10 11 12 13 14
";

    fn be_f32(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_be_bytes()).collect()
    }
    fn be_i32(v: &[i32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_be_bytes()).collect()
    }
    fn be_i64(v: &[i64]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_be_bytes()).collect()
    }
    fn be_f64(v: &[f64]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_be_bytes()).collect()
    }

    const PTS: [f32; 15] = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.];

    /// The same two tets in binary, 4.2 layout.
    pub(crate) fn binary_42() -> Vec<u8> {
        let mut b =
            b"# vtk DataFile Version 4.2\nbin\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 float\n"
                .to_vec();
        b.extend(be_f32(&PTS));
        b.extend(b"\nCELLS 2 10\n");
        b.extend(be_i32(&[4, 0, 1, 2, 3, 4, 1, 2, 3, 4]));
        b.extend(b"\nCELL_TYPES 2\n");
        b.extend(be_i32(&[10, 10]));
        b.extend(b"\nCELL_DATA 2\nVECTORS cv double\n");
        b.extend(be_f64(&[0.0; 6]));
        b.extend(b"\nPOINT_DATA 5\nNORMALS n float\n");
        b.extend(be_f32(&[0.0; 15]));
        b.extend(b"\nSCALARS temp unsigned_short\nLOOKUP_TABLE default\n");
        b.extend([0u16, 1, 2, 3, 4].iter().flat_map(|x| x.to_be_bytes()));
        b.extend(b"\nFIELD f 1\npressure 1 5 double\n");
        b.extend(be_f64(&[10.0, 11.0, 12.0, 13.0, 14.0]));
        b.extend(b"\n");
        b
    }

    /// Binary, 5.1 layout, with a METADATA block.
    pub(crate) fn binary_51() -> Vec<u8> {
        let mut b =
            b"# vtk DataFile Version 5.1\nbin\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 float\n"
                .to_vec();
        b.extend(be_f32(&PTS));
        b.extend(b"\nMETADATA\nINFORMATION 2\nNAME L2_NORM_RANGE LOCATION vtkDataArray\nDATA 2 0 1.73\n\nCELLS 3 8\nOFFSETS vtktypeint64\n");
        b.extend(be_i64(&[0, 4, 8]));
        b.extend(b"\nCONNECTIVITY vtktypeint64\n");
        b.extend(be_i64(&[0, 1, 2, 3, 1, 2, 3, 4]));
        b.extend(b"\nCELL_TYPES 2\n");
        b.extend(be_i32(&[10, 10]));
        b.extend(b"\nPOINT_DATA 5\nSCALARS temp double 1\n");
        b.extend(be_f64(&[0.0, 1.0, 2.0, 3.0, 4.0]));
        b.extend(b"\nSCALARS pressure float\n");
        b.extend(be_f32(&[10.0, 11.0, 12.0, 13.0, 14.0]));
        b.extend(b"\n");
        b
    }

    fn check_two_tets(m: &Mesh) {
        assert_eq!(m.num_vertices(), 5);
        assert_eq!(m.tets(), &[[0, 1, 2, 3], [1, 2, 3, 4]]);
        assert_eq!(m.positions()[4], DVec3::ONE);
        assert_eq!(m.positions()[1], DVec3::X);
        assert_eq!(m.active_field(), ("temp", 0));
        assert_eq!(m.scalars(), &[0.0, 1.0, 2.0, 3.0, 4.0]);
        let names: Vec<&str> = m.fields().iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["temp", "pressure"]);
        assert_eq!(m.fields()[1].steps[0], vec![10.0, 11.0, 12.0, 13.0, 14.0]);
    }

    #[test]
    fn ascii_42_loads() {
        let m = parse_vtk(ASCII_42.as_bytes(), "a.vtk", &LoadOptions::default()).unwrap();
        check_two_tets(&m);
        assert_eq!(m.field_data.get("TIME"), Some(&vec![2.5]));
    }

    #[test]
    fn ascii_51_loads() {
        let m = parse_vtk(ASCII_51.as_bytes(), "a.vtk", &LoadOptions::default()).unwrap();
        check_two_tets(&m);
    }

    #[test]
    fn binary_loads() {
        for b in [binary_42(), binary_51()] {
            let m = parse_vtk(&b, "b.vtk", &LoadOptions::default()).unwrap();
            check_two_tets(&m);
        }
    }

    #[test]
    fn scalar_option_picks_field() {
        let opts = LoadOptions {
            scalar: Some("pressure".into()),
            ..Default::default()
        };
        let m = parse_vtk(ASCII_42.as_bytes(), "a.vtk", &opts).unwrap();
        assert_eq!(m.active_field(), ("pressure", 0));
        let opts = LoadOptions {
            scalar: Some("nope".into()),
            ..Default::default()
        };
        let e = parse_vtk(ASCII_42.as_bytes(), "a.vtk", &opts).unwrap_err();
        assert_eq!(
            e.to_string(),
            "a.vtk: no point field 'nope' (fields: temp, pressure)"
        );
    }

    fn err(s: &str, opts: &LoadOptions) -> String {
        let e = parse_vtk(s.as_bytes(), "x.vtk", opts).unwrap_err();
        assert!(matches!(e, Error::Input(_)), "{e:?}");
        let m = e.to_string();
        assert!(!m.contains('\n'), "{m}");
        assert!(m.starts_with("x.vtk"), "{m}");
        m
    }

    #[test]
    fn bad_files_give_one_line_errors() {
        let d = LoadOptions::default();
        // Truncated.
        let m = err(&ASCII_42[..ASCII_42.find("1 1 1").unwrap()], &d);
        assert!(
            m.contains("x.vtk:8: POINTS: 15 values announced but only 27 bytes"),
            "{m}"
        );
        let m = err(
            &ASCII_42.replace("0 0 1  1 1 1", "0 0 1\n\n\n\n\n\n\n\n\n\n"),
            &d,
        );
        assert!(
            m.contains("x.vtk:21: POINTS: 'CELLS' is not a valid value"),
            "{m}"
        );
        // Counts that disagree with the data.
        let m = err(&ASCII_42.replace("CELLS 2 10", "CELLS 2 11"), &d);
        assert!(m.starts_with("x.vtk:"), "{m}");
        let m = err(&ASCII_42.replace("CELLS 2 10", "CELLS 3 10"), &d);
        assert!(
            m.contains("x.vtk:11: CELLS: the 10 integers hold only 2 of the 3"),
            "{m}"
        );
        let m = err(&ASCII_42.replace("POINT_DATA 5", "POINT_DATA 4"), &d);
        assert!(m.starts_with("x.vtk:"), "{m}");
        // Index out of range.
        let m = err(&ASCII_42.replace("4 1 2 3 4", "4 1 2 3 5"), &d);
        assert!(m.contains("cell 1: vertex index 5 out of range"), "{m}");
        let m = err(&ASCII_42.replace("4 1 2 3 4", "4 1 2 3 -1"), &d);
        assert!(m.contains("out of range"), "{m}");
        // Negative and absurd counts.
        let m = err(&ASCII_42.replace("POINTS 5", "POINTS -5"), &d);
        assert!(m.contains("x.vtk:8: POINTS: negative count -5"), "{m}");
        let m = err(&ASCII_42.replace("POINTS 5", "POINTS 999999999999"), &d);
        assert!(m.contains("x.vtk:8: POINTS"), "{m}");
        let m = err(
            &ASCII_42.replace("POINTS 5", "POINTS 9999999999999999999"),
            &d,
        );
        assert!(m.contains("not a count"), "{m}");
        let m = err(
            &ASCII_42.replace("CELLS 2 10", "CELLS 4000000000 4000000000"),
            &d,
        );
        assert!(m.contains("CELLS"), "{m}");
        // NaN / inf.
        let m = err(&ASCII_42.replace("1 1 1", "1 nan 1"), &d);
        assert!(m.contains("non-finite coordinate"), "{m}");
        let m = err(&ASCII_42.replace("0 1 2 3 4", "0 1 2 inf 4"), &d);
        assert!(m.contains("field 'temp' vertex 3: non-finite"), "{m}");
        // Unknown cell types and non-tet cells without a split.
        let m = err(&ASCII_42.replace("10\n10", "10\n5"), &d);
        assert!(m.contains("VTK type 5 (triangle)"), "{m}");
        let m = err(&ASCII_42.replace("10\n10", "10\n42"), &d);
        assert!(m.contains("VTK type 42"), "{m}");
        // Empty mesh.
        let m = err(
            "# vtk DataFile Version 4.2\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 0 float\nCELLS 0 0\nCELL_TYPES 0\nPOINT_DATA 0\nSCALARS s float\n",
            &d,
        );
        assert!(m.contains("no vertices"), "{m}");
        // Garbage.
        let m = err(&ASCII_42.replace("0 1 2 3 4", "0 1 x 3 4"), &d);
        assert!(
            m.contains("x.vtk:26: SCALARS 'temp': 'x' is not a valid value"),
            "{m}"
        );
        let m = err("hello", &d);
        assert!(m.contains("not a VTK legacy file"), "{m}");
        let m = err(
            &ASCII_42.replace("DATASET UNSTRUCTURED_GRID", "DATASET POLYDATA"),
            &d,
        );
        assert!(m.contains("x.vtk:4: DATASET POLYDATA"), "{m}");
        // Binary with a lying count: refused before allocating.
        let mut b = binary_42();
        let at = b.windows(9).position(|w| w == b"POINTS 5 ").unwrap();
        b.splice(at..at + 8, b"POINTS 2000000000".iter().copied());
        let e = parse_vtk(&b, "b.vtk", &d).unwrap_err().to_string();
        assert!(
            e.starts_with("b.vtk:5: POINTS: 6000000000 values announced"),
            "{e}"
        );
        // Truncated binary.
        let b = binary_51();
        let e = parse_vtk(&b[..b.len() - 10], "b.vtk", &d)
            .unwrap_err()
            .to_string();
        assert!(e.contains("SCALARS 'pressure'"), "{e}");
    }

    #[test]
    fn split_cells_and_structured_grids() {
        let hex = "# vtk DataFile Version 4.2
hex
ASCII
DATASET UNSTRUCTURED_GRID
POINTS 8 float
0 0 0 1 0 0 1 1 0 0 1 0 0 0 1 1 0 1 1 1 1 0 1 1
CELLS 1 9
8 0 1 2 3 4 5 6 7
CELL_TYPES 1
12
POINT_DATA 8
SCALARS s float
0 1 2 3 4 5 6 7
";
        let m = err(hex, &LoadOptions::default());
        assert!(
            m.contains("1 hexahedron cells (VTK type 12) are not tetrahedra"),
            "{m}"
        );
        let opts = LoadOptions {
            split: Some(Split::Five),
            ..Default::default()
        };
        let m = parse_vtk(hex.as_bytes(), "h.vtk", &opts).unwrap();
        assert_eq!((m.num_vertices(), m.num_tets()), (9, 12));
        assert_eq!(m.scalars()[8], 3.5);
        assert_eq!(m.negative_tets(), 0);
        assert!((m.volumes().iter().sum::<f64>() - 1.0).abs() < 1e-12);

        let sg = "# vtk DataFile Version 3.0
sg
ASCII
DATASET STRUCTURED_GRID
DIMENSIONS 2 2 3
POINTS 12 double
0 0 0 1 0 0 0 1 0 1 1 0 0 0 1 1 0 1 0 1 1 1 1 1 0 0 2 1 0 2 0 1 2 1 1 2
POINT_DATA 12
SCALARS s double
0 1 2 3 4 5 6 7 8 9 10 11
";
        let m = err(sg, &LoadOptions::default());
        assert!(m.contains("STRUCTURED_GRID"), "{m}");
        let m = parse_vtk(sg.as_bytes(), "s.vtk", &opts).unwrap();
        assert_eq!(m.num_tets(), 10);
        assert_eq!(m.negative_tets(), 0);
        assert_eq!(m.boundary_faces().len(), 20);
        let six = LoadOptions {
            split: Some(Split::Six),
            ..Default::default()
        };
        assert_eq!(
            parse_vtk(sg.as_bytes(), "s.vtk", &six).unwrap().num_tets(),
            12
        );
        let m = err(&sg.replace("DIMENSIONS 2 2 3", "DIMENSIONS 2 2 4"), &opts);
        assert!(m.contains("x.vtk:5: DIMENSIONS"), "{m}");
    }
    /// Byte-level mutations for the fuzz tests of the `.vtk` and `.vtu` readers.
    pub(crate) mod fuzz {
        use proptest::prelude::*;

        #[derive(Debug, Clone)]
        pub(crate) enum Mutation {
            Set(usize, u8),
            Insert(usize, Vec<u8>),
            Delete(usize, usize),
            Truncate(usize),
        }

        pub(crate) fn mutation() -> impl Strategy<Value = Mutation> {
            let snippets: Vec<Vec<u8>> = [
                &b"9"[..],
                b"99999999999",
                b"-1",
                b"-2147483648",
                b"4294967295",
                b" ",
                b"\n",
                b"nan",
                b"inf",
                b"0",
                b"1e308",
                b"12",
                b"13",
                b"14",
                b"11",
                b"42",
                b"POINTS",
                b"METADATA\n",
                b"\n\n",
                b"<",
                b">",
                b"\"",
                b"_",
                b"=",
                b"\xff\xff\xff\x7f",
            ]
            .iter()
            .map(|s| s.to_vec())
            .collect();
            prop_oneof![
                3 => (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Set(i, b)),
                3 => (any::<usize>(), prop::sample::select(snippets)).prop_map(|(i, s)| Mutation::Insert(i, s)),
                2 => (any::<usize>(), 1usize..16).prop_map(|(i, n)| Mutation::Delete(i, n)),
                1 => any::<usize>().prop_map(Mutation::Truncate),
            ]
        }

        pub(crate) fn apply(base: &[u8], muts: &[Mutation]) -> Vec<u8> {
            let mut b = base.to_vec();
            for m in muts {
                let n = b.len().max(1);
                match m {
                    Mutation::Set(i, v) => {
                        if !b.is_empty() {
                            b[i % n] = *v;
                        }
                    }
                    Mutation::Insert(i, s) => {
                        let at = i % (b.len() + 1);
                        b.splice(at..at, s.iter().copied());
                    }
                    Mutation::Delete(i, k) => {
                        let at = i % n;
                        let end = (at + k).min(b.len());
                        if at < end {
                            b.drain(at..end);
                        }
                    }
                    Mutation::Truncate(i) => b.truncate(i % n),
                }
            }
            b
        }

        pub(crate) fn config() -> ProptestConfig {
            ProptestConfig {
                failure_persistence: None,
                ..ProptestConfig::default()
            }
        }
    }

    mod fuzz_vtk {
        use super::fuzz::*;
        use super::*;
        use proptest::prelude::*;

        proptest! {
            #![proptest_config(config())]
            /// Mutated and truncated ASCII and binary files give Ok or Err, never a panic.
            #[test]
            fn vtk_reader_never_panics(
                which in 0usize..4,
                split in 0usize..3,
                muts in prop::collection::vec(mutation(), 1..6),
            ) {
                let base = match which {
                    0 => ASCII_42.as_bytes().to_vec(),
                    1 => ASCII_51.as_bytes().to_vec(),
                    2 => binary_42(),
                    _ => binary_51(),
                };
                let bytes = apply(&base, &muts);
                let opts = LoadOptions {
                    split: [None, Some(Split::Five), Some(Split::Six)][split],
                    ..Default::default()
                };
                if let Err(e) = parse_vtk(&bytes, "f.vtk", &opts) {
                    let m = e.to_string();
                    prop_assert!(!m.contains('\n'), "{}", m);
                }
            }
        }
    }
}
