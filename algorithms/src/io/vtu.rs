//! VTK XML `.vtu` (UnstructuredGrid) reader.
//!
//! Reads DataArrays in `ascii`, `binary` (base64, `header_type` UInt32 or UInt64, zlib blocks
//! when `compressor="vtkZLibDataCompressor"`) and `appended` format (`AppendedData` raw or
//! base64), either byte order, every numeric type, several pieces. Cells as in `.vtk` (see
//! [`crate::io::split`]). One-component point arrays become named fields (`name_t000`,
//! `name_t001`, … as the time steps of `name`); `<FieldData>` numeric arrays go to
//! `Mesh::field_data`. Hand-written on `quick-xml` for the same reasons as the legacy reader
//! (checked counts, no allocation from a lying header, messages that name line and array);
//! the appended block is cut off before the XML parser sees it, since raw bytes are not XML.
//!
//! The writer is [`crate::io::writers::vtu`].

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use base64::engine::{DecodePaddingMode, GeneralPurpose, GeneralPurposeConfig};
use base64::Engine;
use glam::DVec3;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::error::{Error, Result};
use crate::io::split::{self, DType};
use crate::io::LoadOptions;
use crate::mesh::Mesh;

const B64: GeneralPurpose = GeneralPurpose::new(
    &base64::alphabet::STANDARD,
    GeneralPurposeConfig::new()
        .with_decode_padding_mode(DecodePaddingMode::Indifferent)
        .with_decode_allow_trailing_bits(true),
);

/// Reads a VTK XML UnstructuredGrid file (see the module docs).
pub fn read_vtu(path: &Path, opts: &LoadOptions) -> Result<Mesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_vtu(&bytes, &path.display().to_string(), opts)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Section {
    Points,
    Cells,
    PointData,
    CellData,
    FieldData,
    Other,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    Binary,
    Appended,
}

#[derive(Debug)]
struct Array {
    name: String,
    ty: String,
    ncomp: usize,
    ntuples: Option<usize>,
    format: Format,
    offset: usize,
    text: String,
    pos: usize,
    section: Section,
}

#[derive(Debug, Default)]
struct Piece {
    npts: usize,
    ncells: usize,
    scalars: Option<String>,
    arrays: Vec<Array>,
}

struct Doc<'a> {
    src: &'a str,
    xml: &'a str,
    big: bool,
    hs: usize,
    zlib: bool,
    /// Appended data after the `_`; `true` when raw.
    appended: Option<(bool, &'a [u8])>,
    /// Offsets of every appended array, sorted (to find where a base64 one ends).
    offsets: Vec<usize>,
}

fn line_of(xml: &str, pos: usize) -> usize {
    1 + xml.as_bytes()[..pos.min(xml.len())]
        .iter()
        .filter(|&&c| c == b'\n')
        .count()
}

fn attrs(e: &BytesStart) -> std::result::Result<Vec<(String, String)>, String> {
    let mut out = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|e| format!("bad attribute: {e}"))?;
        let v = a
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|e| format!("bad attribute value: {e}"))?;
        out.push((a.key.as_ref().to_string(), v.into_owned()));
    }
    Ok(out)
}

fn get<'a>(a: &'a [(String, String)], k: &str) -> Option<&'a str> {
    a.iter().find(|(n, _)| n == k).map(|(_, v)| v.as_str())
}

fn one_line(s: &str) -> String {
    s.chars()
        .take(60)
        .collect::<String>()
        .escape_debug()
        .to_string()
}

impl Doc<'_> {
    fn err_at(&self, pos: usize, msg: impl std::fmt::Display) -> Error {
        Error::input(format!("{}:{}", self.src, line_of(self.xml, pos)), msg)
    }

    fn err(&self, a: &Array, msg: impl std::fmt::Display) -> Error {
        self.err_at(
            a.pos,
            format!("DataArray '{}' ({:?}): {msg}", one_line(&a.name), a.section),
        )
    }

    fn dtype(&self, a: &Array) -> Result<DType> {
        DType::from_xml(&a.ty)
            .ok_or_else(|| self.err(a, format!("type '{}' is not numeric", one_line(&a.ty))))
    }

    fn uint(&self, b: &[u8]) -> u64 {
        if self.hs == 8 {
            let mut w = [0u8; 8];
            w.copy_from_slice(&b[..8]);
            if self.big {
                u64::from_be_bytes(w)
            } else {
                u64::from_le_bytes(w)
            }
        } else {
            let mut w = [0u8; 4];
            w.copy_from_slice(&b[..4]);
            (if self.big {
                u32::from_be_bytes(w)
            } else {
                u32::from_le_bytes(w)
            }) as u64
        }
    }

    /// The decoded (and decompressed) bytes of a binary or appended array. `limit`: the byte
    /// count the array must have when known (a compressed array claiming more is refused before
    /// anything is inflated).
    fn payload(&self, a: &Array, limit: Option<u64>) -> Result<Vec<u8>> {
        match a.format {
            Format::Binary => {
                let t: Vec<u8> = a
                    .text
                    .bytes()
                    .filter(|c| !c.is_ascii_whitespace())
                    .collect();
                self.payload_b64(a, &t, limit)
            }
            Format::Appended => {
                let Some((raw, data)) = self.appended else {
                    return Err(self.err(a, "format=\"appended\" but the file has no AppendedData"));
                };
                if a.offset > data.len() {
                    return Err(self.err(
                        a,
                        format!(
                            "offset {} past the {} bytes of appended data",
                            a.offset,
                            data.len()
                        ),
                    ));
                }
                if raw {
                    self.payload_raw(a, &data[a.offset..], limit)
                } else {
                    let end = self
                        .offsets
                        .iter()
                        .copied()
                        .find(|&o| o > a.offset)
                        .unwrap_or(data.len())
                        .min(data.len());
                    let t: Vec<u8> = data[a.offset..end]
                        .iter()
                        .copied()
                        .filter(|c| !c.is_ascii_whitespace())
                        .collect();
                    self.payload_b64(a, &t, limit)
                }
            }
            Format::Ascii => Err(Error::Internal("payload of an ascii array".into())),
        }
    }

    fn payload_raw(&self, a: &Array, s: &[u8], limit: Option<u64>) -> Result<Vec<u8>> {
        let hs = self.hs;
        let short = || self.err(a, "appended data ends inside this array (truncated file?)");
        if s.len() < hs {
            return Err(short());
        }
        let first = self.uint(s);
        if !self.zlib {
            let n = usize::try_from(first).map_err(|_| short())?;
            if n > s.len() - hs {
                return Err(self.err(
                    a,
                    format!(
                        "header says {n} bytes but only {} remain (truncated file?)",
                        s.len() - hs
                    ),
                ));
            }
            return Ok(s[hs..hs + n].to_vec());
        }
        let nb = usize::try_from(first).map_err(|_| short())?;
        let hlen = nb
            .checked_add(3)
            .and_then(|k| k.checked_mul(hs))
            .filter(|&h| h <= s.len())
            .ok_or_else(|| {
                self.err(
                    a,
                    format!("compression header announces {nb} blocks, more than the file holds"),
                )
            })?;
        let header: Vec<u64> = s[hs..hlen].chunks_exact(hs).map(|c| self.uint(c)).collect();
        self.inflate(a, &header, &s[hlen..], limit)
    }

    fn b64(&self, a: &Array, t: &[u8]) -> Result<Vec<u8>> {
        B64.decode(t)
            .map_err(|e| self.err(a, format!("bad base64 data: {e}")))
    }

    fn payload_b64(&self, a: &Array, t: &[u8], limit: Option<u64>) -> Result<Vec<u8>> {
        let hs = self.hs;
        let chars = |bytes: usize| bytes.div_ceil(3).saturating_mul(4);
        let short = || self.err(a, "base64 data too short for its header");
        if !self.zlib {
            // Header and data are one base64 stream (VTK) or two (some writers).
            if let Ok(d) = B64.decode(t) {
                if d.len() >= hs {
                    let n = self.uint(&d);
                    if n <= (d.len() - hs) as u64 {
                        return Ok(d[hs..hs + n as usize].to_vec());
                    }
                }
            }
            let hc = chars(hs);
            if t.len() < hc {
                return Err(short());
            }
            let h = self.b64(a, &t[..hc])?;
            if h.len() < hs {
                return Err(short());
            }
            let n = self.uint(&h);
            let d = self.b64(a, &t[hc..])?;
            if n > d.len() as u64 {
                return Err(self.err(
                    a,
                    format!("header says {n} bytes but the data holds {}", d.len()),
                ));
            }
            return Ok(d[..n as usize].to_vec());
        }
        let hc1 = chars(hs);
        if t.len() < hc1 {
            return Err(short());
        }
        let h1 = self.b64(a, &t[..hc1])?;
        if h1.len() < hs {
            return Err(short());
        }
        let nb = self.uint(&h1);
        let hlen = usize::try_from(nb)
            .ok()
            .and_then(|nb| nb.checked_add(3))
            .and_then(|k| k.checked_mul(hs))
            .filter(|&h| chars(h) <= t.len())
            .ok_or_else(|| {
                self.err(
                    a,
                    format!("compression header announces {nb} blocks, more than the file holds"),
                )
            })?;
        let hc = chars(hlen);
        let h = self.b64(a, &t[..hc])?;
        if h.len() < hlen {
            return Err(short());
        }
        let header: Vec<u64> = h[hs..hlen].chunks_exact(hs).map(|c| self.uint(c)).collect();
        match B64.decode(&t[hc..]) {
            Ok(d) => self.inflate(a, &header, &d, limit),
            Err(_) => {
                let all = self.b64(a, t)?;
                self.inflate(a, &header, all.get(hlen..).unwrap_or(&[]), limit)
            }
        }
    }

    /// `header` = block size, last block size, compressed sizes; `limit` = the bytes the array
    /// must have, when known.
    fn inflate(
        &self,
        a: &Array,
        header: &[u64],
        data: &[u8],
        limit: Option<u64>,
    ) -> Result<Vec<u8>> {
        let (bs, last, sizes) = (header[0], header[1], &header[2..]);
        let nb = sizes.len() as u64;
        if nb == 0 {
            return Ok(Vec::new());
        }
        let last = if last == 0 { bs } else { last };
        let bad = |m: String| self.err(a, m);
        if last > bs {
            return Err(bad(format!(
                "last block size {last} exceeds the block size {bs}"
            )));
        }
        let total = (nb - 1)
            .checked_mul(bs)
            .and_then(|x| x.checked_add(last))
            .ok_or_else(|| bad("block sizes overflow".into()))?;
        let ctotal = sizes
            .iter()
            .try_fold(0u64, |s, &c| s.checked_add(c))
            .filter(|&c| c <= data.len() as u64)
            .ok_or_else(|| {
                bad(format!(
                    "compressed blocks need more than the {} bytes there are (truncated file?)",
                    data.len()
                ))
            })?;
        // zlib cannot expand more than ~1032:1; refuse before allocating for a lying header.
        if total > ctotal.saturating_mul(1100).saturating_add(1024) {
            return Err(bad(format!(
                "header claims {total} bytes uncompressed from {ctotal} compressed"
            )));
        }
        // A decompression bomb (a few MB inflating to GB for 128 points) is refused here, from
        // the header alone, before a byte is inflated.
        if let Some(want) = limit {
            if total > want {
                return Err(bad(format!(
                    "header says {total} bytes uncompressed, but the array's values take {want}"
                )));
            }
        }
        let mut out = Vec::with_capacity(total as usize);
        let mut at = 0usize;
        for (i, &c) in sizes.iter().enumerate() {
            let want = if i as u64 == nb - 1 { last } else { bs };
            let chunk = &data[at..at + c as usize];
            at += c as usize;
            let before = out.len();
            flate2::read::ZlibDecoder::new(chunk)
                .take(want + 1)
                .read_to_end(&mut out)
                .map_err(|e| bad(format!("zlib block {i}: {e}")))?;
            if (out.len() - before) as u64 != want {
                return Err(bad(format!(
                    "zlib block {i} inflates to {} bytes, not {want}",
                    out.len() - before
                )));
            }
        }
        Ok(out)
    }

    fn check_count(&self, a: &Array, got: usize, expected: Option<usize>) -> Result<()> {
        match expected {
            Some(n) if n != got => Err(self.err(a, format!("{got} values, expected {n}"))),
            _ => Ok(()),
        }
    }

    fn ascii<T>(
        &self,
        a: &Array,
        expected: Option<usize>,
        parse: impl Fn(&str) -> Option<T>,
    ) -> Result<Vec<T>> {
        if let Some(n) = expected {
            if n > a.text.len() / 2 + 1 {
                return Err(self.err(a, format!("{n} values expected but the text holds fewer")));
            }
        }
        let v = a
            .text
            .split_ascii_whitespace()
            .map(|t| {
                parse(t)
                    .ok_or_else(|| self.err(a, format!("'{}' is not a valid value", one_line(t))))
            })
            .collect::<Result<Vec<T>>>()?;
        self.check_count(a, v.len(), expected)?;
        Ok(v)
    }

    /// The decoded bytes of a binary (inline or appended) array: a whole number of `ty` values,
    /// `expected` of them when given.
    fn binary(&self, a: &Array, ty: DType, expected: Option<usize>) -> Result<Vec<u8>> {
        let limit = expected.and_then(|n| (n as u64).checked_mul(ty.size() as u64));
        let p = self.payload(a, limit)?;
        if p.len() % ty.size() != 0 {
            return Err(self.err(
                a,
                format!("{} bytes is not a whole number of {:?}", p.len(), ty),
            ));
        }
        self.check_count(a, p.len() / ty.size(), expected)?;
        Ok(p)
    }

    fn floats(&self, a: &Array, expected: Option<usize>) -> Result<Vec<f64>> {
        let ty = self.dtype(a)?;
        if a.format == Format::Ascii {
            return self.ascii(a, expected, |t| t.parse::<f64>().ok());
        }
        let p = self.binary(a, ty, expected)?;
        Ok(split::decode_f64(&p, ty, self.big))
    }

    fn ints(&self, a: &Array, expected: Option<usize>) -> Result<Vec<i64>> {
        let ty = self.dtype(a)?;
        if a.format == Format::Ascii {
            return self.ascii(a, expected, |t| t.parse::<i64>().ok());
        }
        let p = self.binary(a, ty, expected)?;
        split::decode_i64(&p, ty, self.big).map_err(|m| self.err(a, m))
    }
}

/// Parses a `.vtu` file held in memory; `source` names it in messages.
pub fn parse_vtu(bytes: &[u8], source: &str, opts: &LoadOptions) -> Result<Mesh> {
    // Cut the appended block off: raw bytes are not XML.
    let mut xml_end = bytes.len();
    let mut appended_start = None;
    if let Some(i) = find(bytes, b"<AppendedData") {
        if let Some(j) = bytes[i..].iter().position(|&c| c == b'>') {
            xml_end = i + j + 1;
            let mut k = xml_end;
            while k < bytes.len() && bytes[k].is_ascii_whitespace() {
                k += 1;
            }
            if k < bytes.len() && bytes[k] == b'_' {
                appended_start = Some(k + 1);
            }
        }
    }
    let xml = std::str::from_utf8(&bytes[..xml_end]).map_err(|e| {
        let at = e.valid_up_to();
        let line = 1 + bytes[..at].iter().filter(|&&c| c == b'\n').count();
        Error::input(
            format!("{source}:{line}"),
            "not UTF-8 text (binary data outside AppendedData?)",
        )
    })?;
    let mut doc = Doc {
        src: source,
        xml,
        big: false,
        hs: 4,
        zlib: false,
        appended: None,
        offsets: Vec::new(),
    };
    let mut reader = Reader::from_str(xml);
    reader.config_mut().trim_text(false);
    let mut stack: Vec<String> = Vec::new();
    let mut pieces: Vec<Piece> = Vec::new();
    let mut field_arrays: Vec<Array> = Vec::new();
    let mut current: Option<Array> = None;
    let mut seen_root = false;
    let mut appended_raw: Option<bool> = None;
    loop {
        let pos = reader.buffer_position() as usize;
        let ev = match reader.read_event() {
            Ok(ev) => ev,
            Err(e) => {
                let at = reader.error_position() as usize;
                return Err(doc.err_at(at, format!("XML error: {}", one_line(&e.to_string()))));
            }
        };
        let (e, empty) = match ev {
            Event::Eof => break,
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(_) => {
                if stack.pop().as_deref() == Some("DataArray") {
                    if let Some(a) = current.take() {
                        push_array(&mut pieces, &mut field_arrays, a);
                    }
                }
                continue;
            }
            Event::Text(t) => {
                if let Some(a) = current.as_mut() {
                    if stack.last().map(String::as_str) == Some("DataArray") {
                        a.text.push_str(&t);
                    }
                }
                continue;
            }
            Event::CData(t) => {
                if let Some(a) = current.as_mut() {
                    a.text.push_str(&t);
                }
                continue;
            }
            _ => continue,
        };
        let name = e.local_name().as_ref().to_string();
        let at = attrs(&e).map_err(|m| doc.err_at(pos, m))?;
        let parent = stack.last().cloned().unwrap_or_default();
        match name.as_str() {
            "VTKFile" => {
                seen_root = true;
                match get(&at, "type") {
                    Some("UnstructuredGrid") => {}
                    t => {
                        return Err(doc.err_at(
                            pos,
                            format!(
                                "VTKFile type '{}' is not read (only UnstructuredGrid)",
                                one_line(t.unwrap_or(""))
                            ),
                        ))
                    }
                }
                doc.big = match get(&at, "byte_order") {
                    Some("BigEndian") => true,
                    Some("LittleEndian") | None => false,
                    Some(o) => {
                        return Err(doc.err_at(pos, format!("unknown byte_order '{}'", one_line(o))))
                    }
                };
                doc.hs = match get(&at, "header_type") {
                    Some("UInt64") => 8,
                    Some("UInt32") | None => 4,
                    Some(h) => {
                        return Err(
                            doc.err_at(pos, format!("unknown header_type '{}'", one_line(h)))
                        )
                    }
                };
                doc.zlib = match get(&at, "compressor") {
                    None | Some("") => false,
                    Some("vtkZLibDataCompressor") => true,
                    Some(c) => {
                        return Err(doc.err_at(
                            pos,
                            format!(
                                "compressor '{}' is not read (only vtkZLibDataCompressor)",
                                one_line(c)
                            ),
                        ))
                    }
                };
            }
            "Piece" => {
                let count = |k: &str| -> Result<usize> {
                    get(&at, k)
                        .unwrap_or("0")
                        .trim()
                        .parse::<usize>()
                        .map_err(|_| doc.err_at(pos, format!("Piece: bad {k}")))
                };
                pieces.push(Piece {
                    npts: count("NumberOfPoints")?,
                    ncells: count("NumberOfCells")?,
                    ..Default::default()
                });
            }
            "PointData" => {
                if let Some(p) = pieces.last_mut() {
                    p.scalars = get(&at, "Scalars").map(str::to_string);
                }
            }
            "AppendedData" => {
                appended_raw = Some(match get(&at, "encoding") {
                    Some("raw") => true,
                    Some("base64") | None => false,
                    Some(x) => {
                        return Err(doc.err_at(
                            pos,
                            format!("unknown AppendedData encoding '{}'", one_line(x)),
                        ))
                    }
                });
            }
            "DataArray" => {
                let section = match parent.as_str() {
                    "Points" => Section::Points,
                    "Cells" => Section::Cells,
                    "PointData" => Section::PointData,
                    "CellData" => Section::CellData,
                    "FieldData" => Section::FieldData,
                    _ => Section::Other,
                };
                let num = |k: &str, default: usize| -> Result<usize> {
                    match get(&at, k) {
                        None => Ok(default),
                        Some(v) => v.trim().parse::<usize>().map_err(|_| {
                            doc.err_at(pos, format!("DataArray: bad {k} '{}'", one_line(v)))
                        }),
                    }
                };
                let format = match get(&at, "format") {
                    Some("ascii") => Format::Ascii,
                    Some("binary") => Format::Binary,
                    Some("appended") => Format::Appended,
                    None if get(&at, "offset").is_some() => Format::Appended,
                    None => Format::Ascii,
                    Some(f) => {
                        return Err(
                            doc.err_at(pos, format!("DataArray: unknown format '{}'", one_line(f)))
                        )
                    }
                };
                let a = Array {
                    name: get(&at, "Name").unwrap_or("").to_string(),
                    ty: get(&at, "type").unwrap_or("").to_string(),
                    ncomp: num("NumberOfComponents", 1)?,
                    ntuples: get(&at, "NumberOfTuples")
                        .map(|_| num("NumberOfTuples", 0))
                        .transpose()?,
                    format,
                    offset: num("offset", 0)?,
                    text: String::new(),
                    pos,
                    section,
                };
                if format == Format::Appended {
                    doc.offsets.push(a.offset);
                }
                if empty {
                    push_array(&mut pieces, &mut field_arrays, a);
                } else {
                    current = Some(a);
                }
            }
            _ => {}
        }
        if !empty {
            stack.push(name);
        }
    }
    if !seen_root {
        return Err(Error::input(
            source,
            "not a VTK XML file (no VTKFile element)",
        ));
    }
    doc.offsets.sort_unstable();
    if let (Some(raw), Some(s)) = (appended_raw, appended_start) {
        let mut data = &bytes[s..];
        if !raw {
            let end = data.iter().position(|&c| c == b'<').unwrap_or(data.len());
            data = &data[..end];
        }
        doc.appended = Some((raw, data));
    }
    build(&doc, pieces, field_arrays, opts)
}

fn push_array(pieces: &mut [Piece], field: &mut Vec<Array>, a: Array) {
    if a.section == Section::FieldData {
        field.push(a);
    } else if let Some(p) = pieces.last_mut() {
        p.arrays.push(a);
    }
}

fn find(h: &[u8], n: &[u8]) -> Option<usize> {
    h.windows(n.len()).position(|w| w == n)
}

fn build(
    doc: &Doc,
    pieces: Vec<Piece>,
    field_arrays: Vec<Array>,
    opts: &LoadOptions,
) -> Result<Mesh> {
    let src = doc.src;
    if pieces.is_empty() {
        return Err(Error::input(src, "no Piece in the UnstructuredGrid"));
    }
    let mut positions: Vec<DVec3> = Vec::new();
    let mut conn: Vec<i64> = Vec::new();
    let mut offsets: Vec<usize> = vec![0];
    let mut types: Vec<u8> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    let mut values: Vec<Vec<f64>> = Vec::new();
    for (pi, p) in pieces.iter().enumerate() {
        let base = positions.len() as i64;
        let Some(pa) = p.arrays.iter().find(|a| a.section == Section::Points) else {
            return Err(Error::input(
                src,
                format!("piece {pi} has no Points DataArray"),
            ));
        };
        if pa.ncomp != 3 {
            return Err(doc.err(pa, format!("{} components, expected 3", pa.ncomp)));
        }
        let n3 = p
            .npts
            .checked_mul(3)
            .ok_or_else(|| doc.err(pa, "NumberOfPoints too large"))?;
        let xyz = doc.floats(pa, Some(n3))?;
        positions.extend(xyz.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])));
        let cell = |n: &str| {
            p.arrays
                .iter()
                .find(|a| a.section == Section::Cells && a.name == n)
                .ok_or_else(|| Error::input(src, format!("piece {pi}: no Cells DataArray '{n}'")))
        };
        let (ca, oa, ta) = (cell("connectivity")?, cell("offsets")?, cell("types")?);
        let c = doc.ints(ca, None)?;
        let ends = doc.ints(oa, Some(p.ncells))?;
        let t = doc.ints(ta, Some(p.ncells))?;
        let line = line_of(doc.xml, oa.pos);
        let o = split::offsets_from_ends(&format!("{src}:{line}"), "offsets", &ends, c.len())?;
        let cbase = conn.len();
        for (i, &x) in t.iter().enumerate() {
            types.push(u8::try_from(x).map_err(|_| {
                doc.err(
                    ta,
                    format!(
                        "cell {i} has unknown VTK type {x} ({})",
                        split::cell_type_name(x)
                    ),
                )
            })?);
        }
        // Out-of-range indices stay out of range (checked by the splitter).
        conn.extend(
            c.iter()
                .map(|&v| if v < 0 { v } else { v.saturating_add(base) }),
        );
        offsets.extend(o[1..].iter().map(|&x| x + cbase));
        // Point arrays: the first piece decides which.
        let pd: Vec<&Array> = p
            .arrays
            .iter()
            .filter(|a| {
                a.section == Section::PointData && a.ncomp == 1 && DType::from_xml(&a.ty).is_some()
            })
            .collect();
        if pi == 0 {
            for a in &pd {
                names.push(a.name.clone());
                values.push(doc.floats(a, Some(p.npts))?);
            }
        } else {
            for (k, name) in names.iter().enumerate() {
                let Some(a) = pd.iter().find(|a| a.name == *name) else {
                    return Err(Error::input(
                        src,
                        format!("piece {pi} lacks point array '{}'", one_line(name)),
                    ));
                };
                values[k].extend(doc.floats(a, Some(p.npts))?);
            }
        }
    }
    if names.is_empty() {
        return Err(Error::input(
            src,
            "no point scalars (a PointData DataArray with one component)",
        ));
    }
    let mut field_data = BTreeMap::new();
    for a in &field_arrays {
        if DType::from_xml(&a.ty).is_some() {
            let n = a.ntuples.and_then(|t| t.checked_mul(a.ncomp));
            field_data.insert(a.name.clone(), doc.floats(a, n)?);
        }
    }
    let tets = split::split_cells(
        src,
        &types,
        &offsets,
        &conn,
        &mut positions,
        &mut values,
        opts.split,
    )?;
    let fields = split::make_fields(names.into_iter().zip(values).collect());
    let mut mesh = Mesh::new(src, positions, tets, fields)?;
    mesh.field_data = field_data;
    split::select_active(
        &mut mesh,
        src,
        opts.scalar.as_deref(),
        pieces[0].scalars.as_deref(),
    )?;
    Ok(mesh)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::io::write_vtu;
    use crate::io::Split;
    use crate::mesh::Field;
    use std::fmt::Write as _;
    use std::io::Write;

    pub(crate) const ASCII: &str = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
  <UnstructuredGrid>
    <FieldData>
      <DataArray type="Float64" Name="TIME" NumberOfTuples="1" format="ascii">2.5</DataArray>
    </FieldData>
    <Piece NumberOfPoints="5" NumberOfCells="2">
      <PointData Scalars="temp">
        <DataArray type="Float32" Name="vel" NumberOfComponents="3" format="ascii">
          0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
        </DataArray>
        <DataArray type="Float32" Name="pressure" format="ascii">10 11 12 13 14</DataArray>
        <DataArray type="Int32" Name="temp" format="ascii">0 1 2 3 4</DataArray>
      </PointData>
      <CellData>
        <DataArray type="Int32" Name="id" format="ascii">0 1</DataArray>
      </CellData>
      <Points>
        <DataArray type="Float32" NumberOfComponents="3" format="ascii">
          0 0 0 1 0 0 0 1 0 0 0 1 1 1 1
        </DataArray>
      </Points>
      <Cells>
        <DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3 1 2 3 4</DataArray>
        <DataArray type="Int32" Name="offsets" format="ascii">4 8</DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">10 10</DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"#;

    pub(crate) fn two_tets() -> Mesh {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
        let mut m = Mesh::new(
            "t",
            p,
            vec![[0, 1, 2, 3], [1, 2, 3, 4]],
            vec![
                Field {
                    name: "pressure".into(),
                    steps: vec![vec![10.0, 11.0, 12.0, 13.0, 14.0]],
                },
                Field {
                    name: "temp".into(),
                    steps: vec![vec![0.0, 1.0, 2.0, 3.0, 4.0]],
                },
            ],
        )
        .unwrap();
        m.select_field("temp", 0).unwrap();
        m.field_data.insert("TIME".into(), vec![2.5]);
        m
    }

    fn same(a: &Mesh, b: &Mesh) {
        assert_eq!(a.positions().len(), b.positions().len());
        for (p, q) in a.positions().iter().zip(b.positions()) {
            assert_eq!(
                p.to_array().map(f64::to_bits),
                q.to_array().map(f64::to_bits)
            );
        }
        assert_eq!(a.tets(), b.tets());
        assert_eq!(a.fields().len(), b.fields().len());
        for (f, g) in a.fields().iter().zip(b.fields()) {
            assert_eq!(f.name, g.name);
            let bits = |f: &Field| {
                f.steps
                    .iter()
                    .map(|s| s.iter().map(|v| v.to_bits()).collect())
                    .collect::<Vec<Vec<u64>>>()
            };
            assert_eq!(bits(f), bits(g));
        }
        assert_eq!(a.active_field(), b.active_field());
        assert_eq!(a.field_data, b.field_data);
    }

    /// Encodes `m`'s arrays in the other formats, with the given header size and compression.
    pub(crate) fn encoded(m: &Mesh, mode: &str, hs: usize, zlib: bool, big: bool) -> Vec<u8> {
        let hdr = |n: usize| -> Vec<u8> {
            match (hs, big) {
                (8, false) => (n as u64).to_le_bytes().to_vec(),
                (8, true) => (n as u64).to_be_bytes().to_vec(),
                (_, false) => (n as u32).to_le_bytes().to_vec(),
                (_, true) => (n as u32).to_be_bytes().to_vec(),
            }
        };
        // Returns (header bytes, data bytes) of one array.
        let pack = |raw: Vec<u8>| -> (Vec<u8>, Vec<u8>) {
            if !zlib {
                return (hdr(raw.len()), raw);
            }
            let bs = 16usize; // tiny blocks to exercise several
            let mut h = Vec::new();
            let mut d = Vec::new();
            let blocks: Vec<&[u8]> = raw.chunks(bs).collect();
            h.extend(hdr(blocks.len()));
            h.extend(hdr(bs));
            h.extend(hdr(if raw.len().is_multiple_of(bs) {
                0
            } else {
                raw.len() % bs
            }));
            let mut sizes = Vec::new();
            for b in &blocks {
                let mut e =
                    flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
                e.write_all(b).unwrap();
                let c = e.finish().unwrap();
                sizes.push(c.len());
                d.extend(c);
            }
            for s in sizes {
                h.extend(hdr(s));
            }
            (h, d)
        };
        let f64b = |v: &[f64]| -> Vec<u8> {
            v.iter()
                .flat_map(|x| {
                    if big {
                        x.to_be_bytes()
                    } else {
                        x.to_le_bytes()
                    }
                })
                .collect()
        };
        let i32b = |v: &[i32]| -> Vec<u8> {
            v.iter()
                .flat_map(|x| {
                    if big {
                        x.to_be_bytes()
                    } else {
                        x.to_le_bytes()
                    }
                })
                .collect()
        };
        let flat: Vec<f64> = m.positions().iter().flat_map(|p| p.to_array()).collect();
        let conn: Vec<i32> = m.tets().iter().flatten().map(|&v| v as i32).collect();
        let offs: Vec<i32> = (1..=m.num_tets() as i32).map(|i| 4 * i).collect();
        let arrays: Vec<(&str, &str, &str, Vec<u8>)> = vec![
            (
                "PointData",
                "Float64",
                "pressure",
                f64b(&m.fields()[0].steps[0]),
            ),
            (
                "PointData",
                "Float64",
                "temp",
                f64b(&m.fields()[1].steps[0]),
            ),
            ("Points", "Float64", "", f64b(&flat)),
            ("Cells", "Int32", "connectivity", i32b(&conn)),
            ("Cells", "Int32", "offsets", i32b(&offs)),
            ("Cells", "UInt8", "types", vec![10u8; m.num_tets()]),
        ];
        let mut app: Vec<u8> = Vec::new();
        let mut body = String::new();
        let mut section = "";
        for (sec, ty, name, raw) in arrays {
            if sec != section {
                if !section.is_empty() {
                    let _ = writeln!(body, "</{section}>");
                }
                let _ = writeln!(
                    body,
                    "<{sec}{}>",
                    if sec == "PointData" {
                        " Scalars=\"temp\""
                    } else {
                        ""
                    }
                );
                section = sec;
            }
            let nc = if sec == "Points" { 3 } else { 1 };
            let (h, d) = pack(raw);
            match mode {
                "binary" => {
                    let text = if zlib {
                        format!("{}{}", B64.encode(&h), B64.encode(&d))
                    } else {
                        B64.encode([h, d].concat())
                    };
                    let _ = writeln!(body, "<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{nc}\" format=\"binary\">\n  {text}\n</DataArray>");
                }
                "raw" | "base64" => {
                    let off = app.len();
                    if mode == "raw" {
                        app.extend(h);
                        app.extend(d);
                    } else {
                        app.extend(format!("{}{}", B64.encode(&h), B64.encode(&d)).into_bytes());
                    }
                    let _ = writeln!(body, "<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{nc}\" format=\"appended\" offset=\"{off}\"/>");
                }
                _ => unreachable!(),
            }
        }
        let _ = writeln!(body, "</{section}>");
        let mut out = format!(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"{}\" header_type=\"{}\"{}>\n<UnstructuredGrid>\n<FieldData><DataArray type=\"Float64\" Name=\"TIME\" NumberOfTuples=\"1\" format=\"ascii\">2.5</DataArray></FieldData>\n<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n{body}</Piece>\n</UnstructuredGrid>\n",
            if big { "BigEndian" } else { "LittleEndian" },
            if hs == 8 { "UInt64" } else { "UInt32" },
            if zlib { " compressor=\"vtkZLibDataCompressor\"" } else { "" },
            m.num_vertices(),
            m.num_tets()
        )
        .into_bytes();
        if mode != "binary" {
            out.extend(format!("<AppendedData encoding=\"{mode}\">\n  _").into_bytes());
            out.extend(app);
            out.extend(b"\n</AppendedData>\n");
        }
        out.extend(b"</VTKFile>\n");
        out
    }

    #[test]
    fn a_decompression_bomb_is_refused_before_inflating() {
        // 16 MiB of zeros in one zlib block (~16 KB compressed) for a 5-point Float32 array:
        // refused from the header (before the fix it was inflated whole, then counted).
        let raw = vec![0u8; 16 << 20];
        let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
        e.write_all(&raw).unwrap();
        let c = e.finish().unwrap();
        let mut h = Vec::new();
        for x in [1u32, raw.len() as u32, raw.len() as u32, c.len() as u32] {
            h.extend(x.to_le_bytes());
        }
        let arr = format!(
            "<DataArray type=\"Float32\" Name=\"pressure\" format=\"binary\">{}{}</DataArray>",
            B64.encode(&h),
            B64.encode(&c)
        );
        let text = ASCII
            .replace(
                r#"<DataArray type="Float32" Name="pressure" format="ascii">10 11 12 13 14</DataArray>"#,
                &arr,
            )
            .replace(
                r#"byte_order="LittleEndian">"#,
                r#"byte_order="LittleEndian" compressor="vtkZLibDataCompressor">"#,
            );
        assert!(text.contains("vtkZLib") && text.contains("format=\"binary\""));
        let e = parse_vtu(text.as_bytes(), "bomb.vtu", &LoadOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("bomb.vtu:")
                && e.contains("16777216 bytes uncompressed")
                && e.contains("take 20"),
            "{e}"
        );
    }

    #[test]
    fn ascii_loads() {
        let m = parse_vtu(ASCII.as_bytes(), "a.vtu", &LoadOptions::default()).unwrap();
        same(&m, &two_tets());
    }

    #[test]
    fn every_encoding_loads() {
        let want = two_tets();
        for mode in ["binary", "raw", "base64"] {
            for hs in [4, 8] {
                for zlib in [false, true] {
                    for big in [false, true] {
                        let b = encoded(&want, mode, hs, zlib, big);
                        let m = parse_vtu(&b, "e.vtu", &LoadOptions::default())
                            .unwrap_or_else(|e| panic!("{mode} {hs} {zlib} {big}: {e}"));
                        same(&m, &want);
                    }
                }
            }
        }
    }

    #[test]
    fn write_read_round_trip() {
        let dir = std::env::temp_dir().join(format!("vtu-rt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.vtu");
        let mut m = two_tets();
        // Awkward values, a field with steps, odd names.
        m.add_field(Field {
            name: "T <&\"x\">".into(),
            steps: vec![
                vec![0.1, -0.0, 1e-300, f64::MAX, 3.0],
                vec![1.0 / 3.0; 5],
                vec![7.0; 5],
            ],
        })
        .unwrap();
        m.select_field("T <&\"x\">", 2).unwrap();
        m.field_data
            .insert("lattice".into(), vec![1.0, 2.0, std::f64::consts::PI]);
        m.field_data.insert("empty".into(), vec![]);
        write_vtu(&m, &path).unwrap();
        let back = read_vtu(&path, &LoadOptions::default()).unwrap();
        same(&m, &back);
        assert_eq!(back.fields()[2].steps.len(), 3);
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, vec![std::ffi::OsString::from("m.vtu")]);
        // A failing write leaves nothing behind.
        assert!(write_vtu(&m, &dir.join("no/such/dir/x.vtu")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    fn err(b: &[u8]) -> String {
        let e = parse_vtu(b, "x.vtu", &LoadOptions::default()).unwrap_err();
        assert!(matches!(e, Error::Input(_)), "{e:?}");
        let m = e.to_string();
        assert!(!m.contains('\n') && m.starts_with("x.vtu"), "{m}");
        m
    }

    #[test]
    fn bad_files_give_one_line_errors() {
        let m = err(ASCII
            .replace("0 1 2 3 1 2 3 4", "0 1 2 3 1 2 3 9")
            .as_bytes());
        assert!(m.contains("cell 1: vertex index 9 out of range"), "{m}");
        let m = err(ASCII
            .replace(
                "\"offsets\" format=\"ascii\">4 8",
                "\"offsets\" format=\"ascii\">4 9",
            )
            .as_bytes());
        assert!(m.contains("x.vtu:25: offsets"), "{m}");
        let m = err(ASCII.replace("10 10", "10 7").as_bytes());
        assert!(m.contains("VTK type 7 (polygon)"), "{m}");
        let m = err(ASCII.replace("10 11 12 13 14", "10 11 12 13").as_bytes());
        assert!(
            m.contains("x.vtu:12: DataArray 'pressure' (PointData): 4 values, expected 5"),
            "{m}"
        );
        let m = err(ASCII
            .replace("0 0 0 1 0 0 0 1 0", "0 0 0 1 0 0 0 nan 0")
            .as_bytes());
        assert!(m.contains("non-finite coordinate"), "{m}");
        let m = err(ASCII
            .replace("NumberOfPoints=\"5\"", "NumberOfPoints=\"99999999999999\"")
            .as_bytes());
        assert!(m.contains("expected but the text holds fewer"), "{m}");
        let m = err(ASCII
            .replace("NumberOfPoints=\"5\"", "NumberOfPoints=\"-5\"")
            .as_bytes());
        assert!(m.contains("Piece: bad NumberOfPoints"), "{m}");
        let m = err(&ASCII.as_bytes()[..ASCII.find("<Cells>").unwrap()]);
        assert!(m.contains("no Cells DataArray 'connectivity'"), "{m}");
        let m = err(ASCII.replace("</Points>", "</Pointz>").as_bytes());
        assert!(m.contains("XML error"), "{m}");
        let m = err(b"");
        assert!(m.contains("not a VTK XML file"), "{m}");
        let m = err(ASCII
            .replace("UnstructuredGrid\" version", "PolyData\" version")
            .as_bytes());
        assert!(m.contains("x.vtu:2: VTKFile type 'PolyData'"), "{m}");
        // Binary: truncated appended data, lying block counts, lying sizes.
        let want = two_tets();
        let raw = encoded(&want, "raw", 8, false, false);
        let cut = raw.len() - 60;
        let m = err(&raw[..cut]);
        assert!(m.contains("DataArray"), "{m}");
        let z = encoded(&want, "raw", 8, true, false);
        let at = find(&z, b"  _").unwrap() + 3;
        let mut lie = z.clone();
        lie[at..at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        let m = err(&lie);
        assert!(m.contains("blocks, more than the file holds"), "{m}");
        let mut lie = z.clone();
        lie[at + 8..at + 16].copy_from_slice(&(1u64 << 40).to_le_bytes());
        let m = err(&lie);
        assert!(m.contains("uncompressed from"), "{m}");
        let mut lie = raw.clone();
        let at = find(&raw, b"  _").unwrap() + 3;
        lie[at..at + 8].copy_from_slice(&(1u64 << 50).to_le_bytes());
        let m = err(&lie);
        assert!(m.contains("header says"), "{m}");
    }

    #[test]
    fn empty_mesh_and_pieces() {
        let empty = ASCII
            .replace("NumberOfCells=\"2\"", "NumberOfCells=\"0\"")
            .replace(">0 1 2 3 1 2 3 4<", "><")
            .replace(">4 8<", "><")
            .replace(">10 10<", "><");
        let m = err(empty.as_bytes());
        assert!(m.contains("mesh has no tetrahedra"), "{m}");
        // Two pieces of one tet each: indices are per piece.
        let a = ASCII.find("<Piece").unwrap();
        let b = ASCII.find("</Piece>").unwrap() + "</Piece>".len();
        let piece = |conn: &str| {
            ASCII[a..b]
                .replace("NumberOfCells=\"2\"", "NumberOfCells=\"1\"")
                .replace(">0 1 2 3 1 2 3 4<", &format!(">{conn}<"))
                .replace(">4 8<", ">4<")
                .replace(">10 10<", ">10<")
                .replace(">0 1</DataArray>", ">0</DataArray>")
        };
        let two = format!(
            "{}{}{}{}",
            &ASCII[..a],
            piece("0 1 2 3"),
            piece("1 2 3 4"),
            &ASCII[b..]
        );
        let m = parse_vtu(two.as_bytes(), "p.vtu", &LoadOptions::default()).unwrap();
        assert_eq!(m.num_vertices(), 10);
        assert_eq!(m.tets(), &[[0, 1, 2, 3], [6, 7, 8, 9]]);
        assert_eq!(m.scalars()[5..], [0.0, 1.0, 2.0, 3.0, 4.0]);
    }

    #[test]
    fn hexes_split_when_asked() {
        let hex = ASCII
            .replace(
                "NumberOfPoints=\"5\" NumberOfCells=\"2\"",
                "NumberOfPoints=\"8\" NumberOfCells=\"1\"",
            )
            .replace(
                "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0",
                "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0",
            )
            .replace("10 11 12 13 14", "1 1 1 1 1 1 1 1")
            .replace("0 1 2 3 4", "0 1 2 3 4 5 6 7")
            .replace(
                "0 0 0 1 0 0 0 1 0 0 0 1 1 1 1",
                "0 0 0 1 0 0 1 1 0 0 1 0 0 0 1 1 0 1 1 1 1 0 1 1",
            )
            .replace("0 1 2 3 1 2 3 4", "0 1 2 3 4 5 6 7")
            .replace("4 8", "8")
            .replace("10 10", "12")
            .replace(">0 1</DataArray>", ">0</DataArray>");
        let m = err(hex.as_bytes());
        assert!(m.contains("1 hexahedron cells (VTK type 12)"), "{m}");
        let opts = LoadOptions {
            split: Some(Split::Six),
            ..Default::default()
        };
        let m = parse_vtu(hex.as_bytes(), "h.vtu", &opts).unwrap();
        assert_eq!((m.num_vertices(), m.num_tets()), (9, 12));
        assert_eq!(m.negative_tets(), 0);
    }
    mod fuzz_vtu {
        use super::*;
        use crate::io::vtk::tests::fuzz::*;
        use proptest::prelude::*;

        fn samples() -> Vec<Vec<u8>> {
            let m = two_tets();
            let mut v = vec![ASCII.as_bytes().to_vec()];
            for (mode, hs, zlib, big) in [
                ("binary", 4, false, false),
                ("binary", 8, true, true),
                ("raw", 8, false, false),
                ("raw", 4, true, false),
                ("base64", 4, false, true),
                ("base64", 8, true, false),
            ] {
                v.push(encoded(&m, mode, hs, zlib, big));
            }
            v
        }

        proptest! {
            #![proptest_config(config())]
            /// Mutated and truncated ascii, base64, zlib and appended files give Ok or Err, never a panic.
            #[test]
            fn vtu_reader_never_panics(
                which in 0usize..7,
                split in 0usize..2,
                muts in prop::collection::vec(mutation(), 1..6),
            ) {
                thread_local!(static SAMPLES: Vec<Vec<u8>> = samples());
                let bytes = SAMPLES.with(|s| apply(&s[which], &muts));
                let opts = LoadOptions {
                    split: [None, Some(Split::Five)][split],
                    ..Default::default()
                };
                if let Err(e) = parse_vtu(&bytes, "f.vtu", &opts) {
                    let m = e.to_string();
                    prop_assert!(!m.contains('\n'), "{}", m);
                }
            }
        }
    }
}
