//! The sections of a VTK legacy file after its header, one function per keyword, and the mesh
//! made of what they held.

use std::collections::BTreeMap;

use glam::DVec3;

use super::cursor::{count, num_ty, ty_of, Cur, Ty};
use crate::error::{Error, Result};
use crate::io::fields;
use crate::io::split;
use crate::io::vtk_types::{self, DType};
use crate::io::LoadOptions;
use crate::mesh::Mesh;

/// An array name with VTK's `%XX` escapes (spaces and other bytes a legacy name cannot hold)
/// decoded; a `%` not followed by two hex digits stays as it is.
pub(super) fn decode_name(s: &str) -> String {
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

/// Which data section the attributes that follow belong to.
#[derive(Clone, Copy, Default, PartialEq)]
enum Mode {
    #[default]
    None,
    Point(usize),
    Cell(usize),
}

/// What the sections read so far hold, each with the line it started on.
#[derive(Default)]
pub(super) struct Sections {
    points: Option<(usize, Vec<f64>)>,
    dims: Option<(usize, [usize; 3])>,
    cells: Option<(usize, Vec<usize>, Vec<i64>)>,
    types: Option<(usize, Vec<u8>)>,
    /// Point arrays of one component, in file order, as named fields.
    arrays: Vec<(String, Vec<f64>)>,
    point_data_line: Option<(usize, usize)>,
    first_scalars: Option<String>,
    field_data: BTreeMap<String, Vec<f64>>,
    mode: Mode,
}

impl Sections {
    /// Reads the section that starts with the keyword line `w` (line `l`).
    pub(super) fn read(&mut self, c: &mut Cur, l: usize, w: &[&str]) -> Result<()> {
        let kw = w[0].to_ascii_uppercase();
        match kw.as_str() {
            "POINTS" => self.points(c, l, w),
            "DIMENSIONS" => {
                let d = [count(c, l, w, 1)?, count(c, l, w, 2)?, count(c, l, w, 3)?];
                self.dims = Some((l, d));
                Ok(())
            }
            "CELLS" => self.cells(c, l, w),
            "CELL_TYPES" => self.cell_types(c, l, w),
            "POINT_DATA" => {
                let n = count(c, l, w, 1)?;
                self.mode = Mode::Point(n);
                self.point_data_line = Some((l, n));
                Ok(())
            }
            "CELL_DATA" => {
                self.mode = Mode::Cell(count(c, l, w, 1)?);
                Ok(())
            }
            "METADATA" => {
                // A block after a section we have already read: skip to its blank line.
                while let Some((_, s)) = c.raw_line() {
                    if s.iter().all(|b| b.is_ascii_whitespace()) {
                        break;
                    }
                }
                Ok(())
            }
            "FIELD" => self.field(c, l, w),
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
            | "EDGE_FLAGS" => self.attribute(c, l, w, &kw),
            _ => Err(c.err(
                l,
                format!(
                    "unknown keyword '{}'",
                    w[0].chars().take(40).collect::<String>().escape_debug()
                ),
            )),
        }
    }

    /// `POINTS n type`: the positions.
    fn points(&mut self, c: &mut Cur, l: usize, w: &[&str]) -> Result<()> {
        if self.points.is_some() {
            return Err(c.err(l, "a second POINTS section"));
        }
        let n = count(c, l, w, 1)?;
        let ty = num_ty(c, l, "POINTS", w.get(2))?;
        let n3 = n
            .checked_mul(3)
            .ok_or_else(|| c.err(l, "POINTS: count too large"))?;
        let v = c.values(n3, ty, "POINTS", l)?;
        self.points = Some((l, v));
        c.metadata()
    }

    /// `CELLS a b`, in either layout: 5.1's `OFFSETS`/`CONNECTIVITY` arrays (recognised by the
    /// `OFFSETS` line that follows) or 4.2's `k i0 … ik` records.
    fn cells(&mut self, c: &mut Cur, l: usize, w: &[&str]) -> Result<()> {
        if self.cells.is_some() {
            return Err(c.err(l, "a second CELLS section"));
        }
        let a = count(c, l, w, 1)?;
        let b = count(c, l, w, 2)?;
        let (offsets, conn) = if c.peek_word() == "OFFSETS" {
            cells_51(c, a, b)?
        } else {
            cells_42(c, l, a, b)?
        };
        self.cells = Some((l, offsets, conn));
        Ok(())
    }

    /// `CELL_TYPES n`: one VTK type code per cell.
    fn cell_types(&mut self, c: &mut Cur, l: usize, w: &[&str]) -> Result<()> {
        let n = count(c, l, w, 1)?;
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
                            vtk_types::cell_type_name(x)
                        ),
                    ))
                }
            }
        }
        self.types = Some((l, t));
        c.metadata()
    }

    /// `FIELD name n`: before any data section, the data set's field data; in `POINT_DATA`,
    /// arrays of one component become fields; anything else is skipped.
    fn field(&mut self, c: &mut Cur, l: usize, w: &[&str]) -> Result<()> {
        let narr = count(c, l, w, 2)?;
        for _ in 0..narr {
            let Some((la, wa)) = c.keyword_line()? else {
                return Err(c.err(c.line, "FIELD: file ends before all its arrays"));
            };
            if wa.first() == Some(&"NULL_ARRAY") {
                continue;
            }
            if wa.len() < 4 {
                return Err(c.err(la, "FIELD array: expected 'name components tuples type'"));
            }
            let name = decode_name(wa[0]);
            let what = format!("FIELD array '{}'", name.escape_debug());
            let ncomp = count(c, la, &wa, 1)?;
            let ntup = count(c, la, &wa, 2)?;
            let ty = ty_of(c, la, &what, wa.get(3))?;
            let n = ncomp
                .checked_mul(ntup)
                .ok_or_else(|| c.err(la, format!("{what}: size too large")))?;
            match (self.mode, ty) {
                (Mode::None, Ty::Num(d)) => {
                    self.field_data.insert(name, c.values(n, d, &what, la)?);
                }
                (Mode::Point(np), Ty::Num(d)) if ncomp == 1 && ntup == np => {
                    self.arrays.push((name, c.values(n, d, &what, la)?));
                }
                (Mode::Point(np), _) if ntup != np => {
                    return Err(c.err(la, format!("{what}: {ntup} tuples for {np} points")));
                }
                _ => c.skip(n, ty, &what, la)?,
            }
            c.metadata()?;
        }
        Ok(())
    }

    /// A data attribute (`SCALARS`, `VECTORS`, `LOOKUP_TABLE`, …) of the current data section:
    /// point scalars of one component become fields, the rest is skipped.
    fn attribute(&mut self, c: &mut Cur, l: usize, w: &[&str], kw: &str) -> Result<()> {
        let n = match self.mode {
            Mode::Point(n) | Mode::Cell(n) => n,
            Mode::None => {
                return Err(c.err(l, format!("{kw} before POINT_DATA or CELL_DATA")));
            }
        };
        let name = decode_name(w.get(1).copied().unwrap_or(""));
        let name = name.as_str();
        let what = format!("{kw} '{}'", name.escape_debug());
        let src = c.src;
        let too_large = || Error::input(format!("{src}:{l}"), format!("{what}: size too large"));
        let mul = |k: usize| n.checked_mul(k).ok_or_else(too_large);
        match kw {
            "SCALARS" => {
                let ty = ty_of(c, l, &what, w.get(2))?;
                let ncomp = match w.get(3) {
                    None => 1,
                    Some(_) => count(c, l, w, 3)?,
                };
                if !(1..=4).contains(&ncomp) {
                    return Err(c.err(l, format!("{what}: {ncomp} components (1 to 4 allowed)")));
                }
                if c.peek_word() == "LOOKUP_TABLE" {
                    c.keyword_line()?;
                }
                match (self.mode, ty) {
                    (Mode::Point(_), Ty::Num(d)) if ncomp == 1 => {
                        self.arrays
                            .push((name.to_string(), c.values(n, d, &what, l)?));
                        self.first_scalars.get_or_insert_with(|| name.to_string());
                    }
                    _ => c.skip(mul(ncomp)?, ty, &what, l)?,
                }
            }
            "LOOKUP_TABLE" => {
                let size = count(c, l, w, 2)?;
                let m = size
                    .checked_mul(4)
                    .ok_or_else(|| c.err(l, format!("{what}: size too large")))?;
                let ty = if c.binary { DType::U8 } else { DType::F32 };
                c.skip(m, Ty::Num(ty), &what, l)?;
            }
            "COLOR_SCALARS" => {
                let k = count(c, l, w, 2)?;
                let ty = if c.binary { DType::U8 } else { DType::F32 };
                c.skip(mul(k)?, Ty::Num(ty), &what, l)?;
            }
            "TEXTURE_COORDINATES" => {
                let k = count(c, l, w, 2)?;
                let ty = ty_of(c, l, &what, w.get(3))?;
                c.skip(mul(k)?, ty, &what, l)?;
            }
            _ => {
                let k = match kw {
                    "VECTORS" | "NORMALS" => 3,
                    "TENSORS" => 9,
                    "TENSORS6" => 6,
                    _ => 1,
                };
                let ty = ty_of(c, l, &what, w.get(2))?;
                c.skip(mul(k)?, ty, &what, l)?;
            }
        }
        c.metadata()
    }

    /// The mesh the sections describe: positions, point fields, and tets (the cells split, or
    /// the structured grid's hexahedra split as `opts` asks), checked against each other.
    pub(super) fn into_mesh(self, c: &Cur, structured: bool, opts: &LoadOptions) -> Result<Mesh> {
        let source = c.src;
        let Some((pl, xyz)) = self.points else {
            return Err(Error::input(source, "no POINTS section"));
        };
        let mut positions: Vec<DVec3> = xyz
            .chunks_exact(3)
            .map(|p| DVec3::new(p[0], p[1], p[2]))
            .collect();
        let npts = positions.len();
        if let Some((l, n)) = self.point_data_line {
            if n != npts {
                return Err(c.err(
                    l,
                    format!("POINT_DATA {n} differs from the {npts} POINTS (line {pl})"),
                ));
            }
        }
        if self.arrays.is_empty() {
            return Err(Error::input(
                source,
                "no point scalars (a POINT_DATA section with SCALARS or FIELD arrays)",
            ));
        }
        let (names, mut values): (Vec<String>, Vec<Vec<f64>>) = self.arrays.into_iter().unzip();
        let tets = if structured {
            let Some((dl, d)) = self.dims else {
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
            let Some((cl, offsets, conn)) = self.cells else {
                return Err(Error::input(source, "no CELLS section"));
            };
            let Some((tl, types)) = self.types else {
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
        let fields = fields::make_fields(names.into_iter().zip(values).collect());
        let mut mesh = Mesh::new(source, positions, tets, fields)?;
        mesh.field_data = self.field_data;
        fields::select_active(
            &mut mesh,
            source,
            opts.scalar.as_deref(),
            self.first_scalars.as_deref(),
        )?;
        Ok(mesh)
    }
}

/// 5.1 cells after `CELLS a b`: `a` = cells + 1 offsets, `b` = connectivity entries. Returns
/// the offsets (starting at 0) and the connectivity.
fn cells_51(c: &mut Cur, a: usize, b: usize) -> Result<(Vec<usize>, Vec<i64>)> {
    let (l2, w2) = c.keyword_line()?.unwrap_or_default();
    let ty = num_ty(c, l2, "OFFSETS", w2.get(1))?;
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
    let ty = num_ty(c, l3, "CONNECTIVITY", w3.get(1))?;
    let conn = c.ints(b, ty, "CONNECTIVITY", l3)?;
    c.metadata()?;
    let offsets = match offs.split_first() {
        None => vec![0],
        Some((&first, rest)) => {
            if first != 0 {
                return Err(c.err(l2, format!("OFFSETS: first offset is {first}, not 0")));
            }
            if rest.last().is_some_and(|&e| e != b as i64) {
                return Err(c.err(
                    l2,
                    format!(
                        "OFFSETS: last offset {} differs from the {b} CONNECTIVITY entries",
                        rest[rest.len() - 1]
                    ),
                ));
            }
            split::offsets_from_ends(&format!("{}:{l2}", c.src), "OFFSETS", rest, conn.len())?
        }
    };
    Ok((offsets, conn))
}

/// 4.2 cells after `CELLS a b` (line `l`): `a` cells, `b` integers in `k i0 … ik` records.
/// Returns the offsets (starting at 0) and the connectivity.
fn cells_42(c: &mut Cur, l: usize, a: usize, b: usize) -> Result<(Vec<usize>, Vec<i64>)> {
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
                format!(
                    "CELLS: record of cell {cell} (size {k}) runs past the {b} integers announced"
                ),
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
    Ok((offsets, conn))
}
