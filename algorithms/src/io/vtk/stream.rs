//! Reading a legacy `.vtk` as a stream: a BINARY `UNSTRUCTURED_GRID` of tets in the 5.1
//! layout (`OFFSETS`/`CONNECTIVITY`, what VTK 9, ParaView and tetbench write) is read through a
//! buffered reader straight into the mesh's arrays, a block at a time, so the peak is the mesh
//! and a block. The offsets and cell types are checked as they pass and never kept.
//!
//! Only that subset is read here, and nothing here reports an error in the file: anything else
//! (ASCII, 4.2 cells, cells to split, `METADATA`, a section out of place, a count that does not
//! agree) makes [`stream_vtk`] give up, and the file is read whole by [`super::parse_vtk`],
//! which names what is wrong.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};

use glam::DVec3;

use super::sections::decode_name;
use crate::error::{Error, Result};
use crate::io::fields;
use crate::io::vtk_types::{self, DType};
use crate::io::LoadOptions;
use crate::mesh::Mesh;

/// Bytes decoded at a time: a whole number of values of three or four components of every
/// numeric type.
const BLOCK: usize = 3 * 4 * 8 * 1024;

/// The longest keyword line taken: a longer one is not in the subset read here.
const MAX_LINE: u64 = 4096;

/// Gives up on the stream (the file is then read whole).
macro_rules! want {
    ($c:expr) => {
        if !$c {
            return Ok(None);
        }
    };
}

/// The file, read forward only.
struct In {
    r: BufReader<File>,
    line: Vec<u8>,
}

impl In {
    /// The next line as it is (without `\r\n`), or `None` at the end, past [`MAX_LINE`] or
    /// when it is not text.
    fn raw_line(&mut self) -> std::io::Result<Option<String>> {
        self.line.clear();
        let n = (&mut self.r)
            .take(MAX_LINE)
            .read_until(b'\n', &mut self.line)?;
        if n == 0 || self.line.last() != Some(&b'\n') {
            return Ok(None);
        }
        let s = std::str::from_utf8(&self.line).ok();
        Ok(s.map(|s| s.trim_end_matches(['\n', '\r']).to_string()))
    }

    /// Skips whitespace; `false` at the end of the file.
    fn skip_ws(&mut self) -> std::io::Result<bool> {
        loop {
            let b = self.r.fill_buf()?;
            if b.is_empty() {
                return Ok(false);
            }
            let k = b.iter().take_while(|c| c.is_ascii_whitespace()).count();
            let all = k == b.len();
            self.r.consume(k);
            if !all {
                return Ok(true);
            }
        }
    }

    /// The next non-blank line split into words; `Some(empty)` at the end of the file.
    fn words(&mut self) -> std::io::Result<Option<Vec<String>>> {
        if !self.skip_ws()? {
            return Ok(Some(Vec::new()));
        }
        Ok(self
            .raw_line()?
            .map(|s| s.split_whitespace().map(str::to_string).collect()))
    }

    /// Whether the next word (after whitespace) starts with `kw`, looked at without consuming
    /// anything (binary data may follow); `None` when the buffer cannot tell.
    fn next_is(&mut self, kw: &[u8]) -> std::io::Result<Option<bool>> {
        let b = self.r.fill_buf()?;
        let k = b.iter().take_while(|c| c.is_ascii_whitespace()).count();
        let rest = &b[k..];
        Ok(if rest.len() >= kw.len() {
            Some(rest.starts_with(kw))
        } else {
            None
        })
    }

    /// `n` big-endian values of `ty`, handed to `f` a block at a time.
    fn blocks(&mut self, n: usize, ty: DType, mut f: impl FnMut(&[u8]) -> bool) -> Result<bool> {
        let Some(mut left) = n.checked_mul(ty.size()) else {
            return Ok(false);
        };
        let mut buf = vec![0u8; BLOCK.min(left)];
        while left > 0 {
            let k = BLOCK.min(left);
            if self.r.read_exact(&mut buf[..k]).is_err() || !f(&buf[..k]) {
                return Ok(false);
            }
            left -= k;
        }
        Ok(true)
    }

    /// `n` values of `ty` as f64, in one vector of that size.
    fn floats(&mut self, n: usize, ty: DType) -> Result<Option<Vec<f64>>> {
        let mut v = crate::util::alloc::try_vec_with_capacity::<f64>(n)?;
        let ok = self.blocks(n, ty, |b| {
            v.extend(vtk_types::decode_f64(b, ty, true));
            true
        })?;
        Ok(ok.then_some(v))
    }
}

/// A count word, or `None`.
fn count(w: &[String], i: usize) -> Option<usize> {
    w.get(i)?.parse::<usize>().ok()
}

/// A legacy type word, or `None`.
fn ty(w: &[String], i: usize) -> Option<DType> {
    DType::from_legacy(w.get(i)?)
}

/// The mesh of a BINARY 5.1 all-tet `UNSTRUCTURED_GRID` (see the module docs) read from
/// `file`, or `None` when the file is not such a one.
pub(super) fn stream_vtk(file: File, source: &str, opts: &LoadOptions) -> Result<Option<Mesh>> {
    let mut f = In {
        r: BufReader::with_capacity(1 << 16, file),
        line: Vec::new(),
    };
    let io = |e: std::io::Error| Error::input(source, e);
    let head = f.raw_line().map_err(io)?.unwrap_or_default();
    want!(head
        .trim()
        .to_ascii_lowercase()
        .starts_with("# vtk datafile version"));
    want!(f.raw_line().map_err(io)?.is_some());
    let mode = f.words().map_err(io)?.unwrap_or_default();
    want!(mode.len() == 1 && mode[0].eq_ignore_ascii_case("BINARY"));
    let ds = f.words().map_err(io)?.unwrap_or_default();
    want!(ds.len() == 2 && ds[1].eq_ignore_ascii_case("UNSTRUCTURED_GRID"));

    let mut positions: Option<Vec<DVec3>> = None;
    let mut tets: Option<Vec<[u32; 4]>> = None;
    let mut types_ok = false;
    let mut point_data = None;
    let mut arrays: Vec<(String, Vec<f64>)> = Vec::new();
    let mut first_scalars: Option<String> = None;
    let mut field_data = BTreeMap::new();
    loop {
        let Some(w) = f.words().map_err(io)? else {
            return Ok(None);
        };
        if w.is_empty() {
            break;
        }
        match w[0].to_ascii_uppercase().as_str() {
            "POINTS" if positions.is_none() && w.len() == 3 => {
                let (Some(n), Some(t)) = (count(&w, 1), ty(&w, 2)) else {
                    return Ok(None);
                };
                let Some(n3) = n.checked_mul(3) else {
                    return Ok(None);
                };
                let mut p = crate::util::alloc::try_vec_with_capacity::<DVec3>(n)?;
                let ok = f.blocks(n3, t, |b| {
                    let xyz = vtk_types::decode_f64(b, t, true);
                    p.extend(xyz.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])));
                    true
                })?;
                want!(ok);
                positions = Some(p);
            }
            "CELLS" if tets.is_none() && w.len() == 3 => {
                let (Some(a), Some(b)) = (count(&w, 1), count(&w, 2)) else {
                    return Ok(None);
                };
                let Some(npts) = positions.as_ref().map(Vec::len) else {
                    return Ok(None);
                };
                let ncells = a.saturating_sub(1);
                want!(a >= 1 && Some(b) == ncells.checked_mul(4));
                let ow = f.words().map_err(io)?.unwrap_or_default();
                want!(ow.len() == 2 && ow[0].eq_ignore_ascii_case("OFFSETS"));
                let Some(ot) = ty(&ow, 1) else {
                    return Ok(None);
                };
                // Offsets 0, 4, 8, …: every cell of four points.
                let mut k = 0i64;
                let ok = f.blocks(a, ot, |bytes| {
                    let Ok(o) = vtk_types::decode_i64(bytes, ot, true) else {
                        return false;
                    };
                    o.iter().all(|&x| {
                        let at = x == k;
                        k += 4;
                        at
                    })
                })?;
                want!(ok);
                let cw = f.words().map_err(io)?.unwrap_or_default();
                want!(cw.len() == 2 && cw[0].eq_ignore_ascii_case("CONNECTIVITY"));
                let Some(ct) = ty(&cw, 1) else {
                    return Ok(None);
                };
                let mut t = crate::util::alloc::try_vec_with_capacity::<[u32; 4]>(ncells)?;
                let ok = f.blocks(b, ct, |bytes| {
                    let Ok(c) = vtk_types::decode_i64(bytes, ct, true) else {
                        return false;
                    };
                    for q in c.chunks_exact(4) {
                        let mut tet = [0u32; 4];
                        for (d, &v) in tet.iter_mut().zip(q) {
                            match u32::try_from(v) {
                                Ok(v) if (v as usize) < npts => *d = v,
                                _ => return false,
                            }
                        }
                        t.push(tet);
                    }
                    true
                })?;
                want!(ok);
                tets = Some(t);
            }
            "CELL_TYPES" if w.len() == 2 => {
                let n = count(&w, 1);
                want!(n.is_some() && n == tets.as_ref().map(Vec::len));
                let tetra = i64::from(vtk_types::VTK_TETRA);
                let ok = f.blocks(n.unwrap_or(0), DType::I32, |b| {
                    vtk_types::decode_i64(b, DType::I32, true)
                        .is_ok_and(|t| t.iter().all(|&x| x == tetra))
                })?;
                want!(ok);
                types_ok = true;
            }
            "POINT_DATA" if point_data.is_none() && w.len() == 2 => {
                let n = count(&w, 1);
                want!(n.is_some() && n == positions.as_ref().map(Vec::len));
                point_data = n;
            }
            "SCALARS" if (3..=4).contains(&w.len()) => {
                let Some(n) = point_data else {
                    return Ok(None);
                };
                let Some(t) = ty(&w, 2) else {
                    return Ok(None);
                };
                want!(w.len() == 3 || w[3] == "1");
                match f.next_is(b"LOOKUP_TABLE").map_err(io)? {
                    None => return Ok(None),
                    Some(true) => {
                        f.skip_ws().map_err(io)?;
                        want!(f.raw_line().map_err(io)?.is_some());
                    }
                    Some(false) => {}
                }
                let Some(v) = f.floats(n, t)? else {
                    return Ok(None);
                };
                let name = decode_name(&w[1]);
                first_scalars.get_or_insert_with(|| name.clone());
                arrays.push((name, v));
            }
            "FIELD" if w.len() == 3 => {
                let Some(narr) = count(&w, 2) else {
                    return Ok(None);
                };
                for _ in 0..narr {
                    let a = f.words().map_err(io)?.unwrap_or_default();
                    want!(a.len() == 4);
                    let (Some(nc), Some(nt), Some(t)) = (count(&a, 1), count(&a, 2), ty(&a, 3))
                    else {
                        return Ok(None);
                    };
                    let name = decode_name(&a[0]);
                    match point_data {
                        None => {
                            let Some(n) = nc.checked_mul(nt) else {
                                return Ok(None);
                            };
                            let Some(v) = f.floats(n, t)? else {
                                return Ok(None);
                            };
                            field_data.insert(name, v);
                        }
                        Some(np) => {
                            want!(nc == 1 && nt == np);
                            let Some(v) = f.floats(np, t)? else {
                                return Ok(None);
                            };
                            arrays.push((name, v));
                        }
                    }
                }
            }
            _ => return Ok(None),
        }
    }
    let (Some(positions), Some(tets)) = (positions, tets) else {
        return Ok(None);
    };
    want!(types_ok && point_data.is_some() && !arrays.is_empty());
    let fields = fields::make_fields(arrays);
    let mut mesh = Mesh::new(source, positions, tets, fields)?;
    mesh.field_data = field_data;
    fields::select_active(
        &mut mesh,
        source,
        opts.scalar.as_deref(),
        first_scalars.as_deref(),
    )?;
    Ok(Some(mesh))
}
