//! Reading a `.vtu` file as a stream: the XML head is read up to the appended block, and the
//! arrays of a single-piece, all-tet mesh stored as raw appended data (what tetbench, VTK and
//! ParaView write for large meshes) are read through a buffered reader straight into the
//! mesh's arrays, a block at a time, so the peak is the mesh and a block. Any other file
//! (arrays inline in the XML, base64 or compressed appended data, several pieces, cells to
//! split) is read whole and parsed by [`super::parse_vtu`].

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use glam::DVec3;

use super::data::Doc;
use super::read::{cut_appended, find, parse_vtu, walk, xml_text, Head};
use super::{Array, Format, Piece, Section};
use crate::error::{Error, Result};
use crate::io::fields;
use crate::io::vtk_types::{self, DType};
use crate::io::LoadOptions;
use crate::mesh::Mesh;

/// The most XML read before the appended block: a head past this holds its arrays inline, and
/// the file is read whole.
const MAX_HEAD: usize = 64 << 20;

/// Bytes decoded at a time: a whole number of values of three or four components of every
/// numeric type (1, 2, 4 or 8 bytes).
const BLOCK: usize = 3 * 4 * 8 * 1024;

/// Reads a VTK XML UnstructuredGrid file (see the module docs).
pub fn read_vtu(path: &Path, opts: &LoadOptions) -> Result<Mesh> {
    let source = path.display().to_string();
    let file = crate::io::open_input(path)?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut r = BufReader::with_capacity(1 << 16, file);
    let io = |e: std::io::Error| Error::io(path, e);
    // The head: up to and past `<AppendedData …>` and its `_`, or the whole file.
    let mut head: Vec<u8> = Vec::new();
    let (mut scanned, mut tag): (usize, Option<usize>) = (0, None);
    let found = loop {
        // `<AppendedData` may straddle two reads: searched from a little before the new bytes.
        let from = scanned.saturating_sub(64);
        if let Some(i) = tag.or_else(|| find(&head[from..], b"<AppendedData").map(|j| from + j)) {
            tag = Some(i);
            if let (_, Some(s)) = cut_appended(&head[i..]) {
                break Some(i + s);
            }
            if head.len() - i > 4096 {
                break None;
            }
        }
        scanned = head.len();
        let n = r.fill_buf().map_err(io)?.len();
        if n == 0 || head.len() > MAX_HEAD {
            break None;
        }
        head.extend_from_slice(r.buffer());
        r.consume(n);
    };
    let Some(data_start) = found else {
        return whole(r, head, &source, opts, path);
    };
    let (xml_end, _) = cut_appended(&head);
    let xml = xml_text(&head[..xml_end], &source)?;
    let mut doc = Doc {
        src: &source,
        xml,
        big: false,
        hs: 4,
        zlib: false,
        appended: None,
        offsets: Vec::new(),
    };
    let h = walk(&mut doc)?;
    let mut file = Appended {
        r,
        start: data_start as u64,
        len,
    };
    match stream_mesh(&doc, &h, &mut file, opts)? {
        Some(mesh) => Ok(mesh),
        None => {
            let mut r = file.r;
            r.seek(SeekFrom::Start(head.len() as u64)).map_err(io)?;
            whole(r, head, &source, opts, path)
        }
    }
}

/// Reads the rest of the file after `head` and parses it whole.
fn whole(
    mut r: BufReader<File>,
    mut head: Vec<u8>,
    source: &str,
    opts: &LoadOptions,
    path: &Path,
) -> Result<Mesh> {
    r.read_to_end(&mut head).map_err(|e| Error::io(path, e))?;
    parse_vtu(&head, source, opts)
}

/// The appended block of a file: raw arrays at offsets from `start`, a header of the array's
/// byte count before each.
struct Appended {
    r: BufReader<File>,
    start: u64,
    len: u64,
}

impl Appended {
    /// Positions the reader at array `a`'s values after checking that its header announces
    /// `count` values of `ty` and that the file holds them.
    fn open(&mut self, doc: &Doc, a: &Array, ty: DType, count: usize) -> Result<()> {
        let at = self.start.saturating_add(a.offset as u64);
        let hs = doc.hs as u64;
        if at.saturating_add(hs) > self.len {
            return Err(doc.err(
                a,
                format!(
                    "offset {} past the {} bytes of appended data",
                    a.offset,
                    self.len - self.start
                ),
            ));
        }
        self.r
            .seek(SeekFrom::Start(at))
            .map_err(|e| doc.err(a, e))?;
        let mut h = [0u8; 8];
        self.r
            .read_exact(&mut h[..doc.hs])
            .map_err(|e| doc.err(a, e))?;
        let n = doc.uint(&h);
        let want = (count as u64).checked_mul(ty.size() as u64);
        if want != Some(n) {
            return Err(doc.err(
                a,
                format!(
                    "header says {n} bytes, but {count} values of {ty:?} take {}",
                    want.map_or("more than 2^64".to_string(), |w| w.to_string())
                ),
            ));
        }
        if n > self.len - at - hs {
            return Err(doc.err(
                a,
                format!(
                    "header says {n} bytes but only {} remain (truncated file?)",
                    self.len - at - hs
                ),
            ));
        }
        Ok(())
    }

    /// Reads `count` values of `ty` of array `a` (after [`Appended::open`]) a block at a
    /// time, handing each block's bytes to `f`.
    fn blocks(
        &mut self,
        doc: &Doc,
        a: &Array,
        ty: DType,
        count: usize,
        mut f: impl FnMut(&[u8]) -> Result<()>,
    ) -> Result<()> {
        self.open(doc, a, ty, count)?;
        let mut left = count * ty.size();
        let mut buf = vec![0u8; BLOCK.min(left)];
        while left > 0 {
            let n = BLOCK.min(left);
            self.r
                .read_exact(&mut buf[..n])
                .map_err(|e| doc.err(a, e))?;
            f(&buf[..n])?;
            left -= n;
        }
        Ok(())
    }

    /// Array `a` as `count` f64 values, read into one vector of that size.
    fn floats(&mut self, doc: &Doc, a: &Array, count: usize) -> Result<Vec<f64>> {
        let ty = doc.dtype(a)?;
        let mut out =
            crate::util::alloc::try_vec_with_capacity::<f64>(count).map_err(|e| doc.err(a, e))?;
        self.blocks(doc, a, ty, count, |b| {
            out.extend(vtk_types::decode_f64(b, ty, doc.big));
            Ok(())
        })?;
        Ok(out)
    }
}

/// The mesh of a single-piece, all-tet `.vtu` whose arrays are raw appended data, read a block
/// at a time; `None` when the file is not such a one.
fn stream_mesh(
    doc: &Doc,
    h: &Head,
    file: &mut Appended,
    opts: &LoadOptions,
) -> Result<Option<Mesh>> {
    let src = doc.src;
    if h.appended_raw != Some(true) || doc.zlib || h.pieces.len() != 1 {
        return Ok(None);
    }
    let p: &Piece = &h.pieces[0];
    let appended = |a: &&Array| a.format == Format::Appended;
    let cell = |n: &str| {
        p.arrays
            .iter()
            .find(|a| a.section == Section::Cells && a.name == n)
    };
    let Some(pa) = p.arrays.iter().find(|a| a.section == Section::Points) else {
        return Ok(None);
    };
    let (Some(ca), Some(oa), Some(ta)) = (cell("connectivity"), cell("offsets"), cell("types"))
    else {
        return Ok(None);
    };
    let point_arrays: Vec<&Array> = p
        .arrays
        .iter()
        .filter(|a| {
            a.section == Section::PointData && a.ncomp == 1 && DType::from_xml(&a.ty).is_some()
        })
        .collect();
    let field_arrays: Vec<&Array> = h
        .field_arrays
        .iter()
        .filter(|a| DType::from_xml(&a.ty).is_some())
        .collect();
    let mut every = [pa, ca, oa, ta]
        .into_iter()
        .chain(point_arrays.iter().copied())
        .chain(field_arrays.iter().copied());
    if !every.all(|a| appended(&a))
        || pa.ncomp != 3
        || field_arrays.iter().any(|a| a.ntuples.is_none())
    {
        return Ok(None);
    }
    let (npts, ncells) = (p.npts, p.ncells);
    // Types and offsets first, in one pass each without keeping them: all tets, or the file is
    // read whole (cells to split).
    let tt = doc.dtype(ta)?;
    let mut all_tets = true;
    file.blocks(doc, ta, tt, ncells, |b| {
        let t = vtk_types::decode_i64(b, tt, doc.big).map_err(|m| doc.err(ta, m))?;
        all_tets &= t.iter().all(|&x| x == i64::from(vtk_types::VTK_TETRA));
        Ok(())
    })?;
    let ot = doc.dtype(oa)?;
    let mut k = 0i64;
    file.blocks(doc, oa, ot, ncells, |b| {
        let o = vtk_types::decode_i64(b, ot, doc.big).map_err(|m| doc.err(oa, m))?;
        for x in o {
            k += 4;
            all_tets &= x == k;
        }
        Ok(())
    })?;
    if !all_tets {
        return Ok(None);
    }
    let n4 = ncells
        .checked_mul(4)
        .ok_or_else(|| doc.err(ca, "NumberOfCells too large"))?;
    let ct = doc.dtype(ca)?;
    let mut tets = crate::util::alloc::try_vec_with_capacity::<[u32; 4]>(ncells)
        .map_err(|e| doc.err(ca, e))?;
    file.blocks(doc, ca, ct, n4, |b| {
        let c = vtk_types::decode_i64(b, ct, doc.big).map_err(|m| doc.err(ca, m))?;
        for q in c.chunks_exact(4) {
            let mut t = [0u32; 4];
            for (d, &v) in t.iter_mut().zip(q) {
                *d = u32::try_from(v)
                    .ok()
                    .filter(|&v| (v as usize) < npts)
                    .ok_or_else(|| {
                        doc.err(
                            ca,
                            format!(
                                "cell {}: point index {v} out of range (points: {npts})",
                                tets.len()
                            ),
                        )
                    })?;
            }
            tets.push(t);
        }
        Ok(())
    })?;
    let n3 = npts
        .checked_mul(3)
        .ok_or_else(|| doc.err(pa, "NumberOfPoints too large"))?;
    let pt = doc.dtype(pa)?;
    let mut positions =
        crate::util::alloc::try_vec_with_capacity::<DVec3>(npts).map_err(|e| doc.err(pa, e))?;
    file.blocks(doc, pa, pt, n3, |b| {
        let xyz = vtk_types::decode_f64(b, pt, doc.big);
        positions.extend(xyz.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])));
        Ok(())
    })?;
    if point_arrays.is_empty() {
        return Err(Error::input(
            src,
            "no point scalars (a PointData DataArray with one component)",
        ));
    }
    let mut arrays = Vec::with_capacity(point_arrays.len());
    for a in &point_arrays {
        arrays.push((a.name.clone(), file.floats(doc, a, npts)?));
    }
    let mut field_data = BTreeMap::new();
    for a in &field_arrays {
        let n = a
            .ntuples
            .and_then(|t| t.checked_mul(a.ncomp))
            .ok_or_else(|| doc.err(a, "NumberOfTuples too large"))?;
        field_data.insert(a.name.clone(), file.floats(doc, a, n)?);
    }
    let fields = fields::make_fields(arrays);
    let mut mesh = Mesh::new(src, positions, tets, fields)?;
    mesh.field_data = field_data;
    fields::select_active(&mut mesh, src, opts.scalar.as_deref(), p.scalars.as_deref())?;
    Ok(Some(mesh))
}
