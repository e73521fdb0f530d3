//! Parsing a `.vtu` file: the XML walked for pieces and arrays (the appended block cut off
//! first), then the mesh made of the first piece's points, cells and point arrays.

use std::collections::BTreeMap;

use glam::DVec3;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use super::data::Doc;
use super::{Array, Format, Piece, Section};
use crate::error::{Error, Result};
use crate::io::fields;
use crate::io::split;
use crate::io::vtk_types::{self, DType};
use crate::io::LoadOptions;
use crate::mesh::Mesh;

pub(super) fn line_of(xml: &str, pos: usize) -> usize {
    1 + xml.as_bytes()[..pos.min(xml.len())]
        .iter()
        .filter(|&&c| c == b'\n')
        .count()
}

pub(super) fn attrs(e: &BytesStart) -> std::result::Result<Vec<(String, String)>, String> {
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

pub(super) fn get<'a>(a: &'a [(String, String)], k: &str) -> Option<&'a str> {
    a.iter().find(|(n, _)| n == k).map(|(_, v)| v.as_str())
}

pub(super) fn one_line(s: &str) -> String {
    s.chars()
        .take(60)
        .collect::<String>()
        .escape_debug()
        .to_string()
}

/// Where the XML of a `.vtu` held in `bytes` ends (past `<AppendedData …>`, or the whole
/// file), and where its appended data starts (past the `_`), when it has any.
pub(super) fn cut_appended(bytes: &[u8]) -> (usize, Option<usize>) {
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
    (xml_end, appended_start)
}

/// The XML of a `.vtu` as text, or one line saying where it is not UTF-8.
pub(super) fn xml_text<'a>(bytes: &'a [u8], source: &str) -> Result<&'a str> {
    std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        let line = 1 + bytes[..at].iter().filter(|&&c| c == b'\n').count();
        Error::input(
            format!("{source}:{line}"),
            "not UTF-8 text (binary data outside AppendedData?)",
        )
    })
}

/// What the XML of a `.vtu` says: its pieces, field data arrays and whether its appended data
/// (if any) is raw.
pub(super) struct Head {
    pub(super) pieces: Vec<Piece>,
    pub(super) field_arrays: Vec<Array>,
    pub(super) appended_raw: Option<bool>,
}

/// Parses a `.vtu` file held in memory; `source` names it in messages.
pub fn parse_vtu(bytes: &[u8], source: &str, opts: &LoadOptions) -> Result<Mesh> {
    // Cut the appended block off: raw bytes are not XML.
    let (xml_end, appended_start) = cut_appended(bytes);
    let xml = xml_text(&bytes[..xml_end], source)?;
    let mut doc = Doc {
        src: source,
        xml,
        big: false,
        hs: 4,
        zlib: false,
        appended: None,
        offsets: Vec::new(),
    };
    let head = walk(&mut doc)?;
    if let (Some(raw), Some(s)) = (head.appended_raw, appended_start) {
        let mut data = &bytes[s..];
        if !raw {
            let end = data.iter().position(|&c| c == b'<').unwrap_or(data.len());
            data = &data[..end];
        }
        doc.appended = Some((raw, data));
    }
    build(&doc, head.pieces, head.field_arrays, opts)
}

/// Walks the XML of `doc`, setting its byte order, header size, compressor and appended
/// offsets, and collecting its pieces and arrays.
pub(super) fn walk(doc: &mut Doc) -> Result<Head> {
    let (source, xml) = (doc.src, doc.xml);
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
    Ok(Head {
        pieces,
        field_arrays,
        appended_raw,
    })
}

pub(super) fn push_array(pieces: &mut [Piece], field: &mut Vec<Array>, a: Array) {
    if a.section == Section::FieldData {
        field.push(a);
    } else if let Some(p) = pieces.last_mut() {
        p.arrays.push(a);
    }
}

pub(super) fn find(h: &[u8], n: &[u8]) -> Option<usize> {
    h.windows(n.len()).position(|w| w == n)
}

pub(super) fn build(
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
                        vtk_types::cell_type_name(x)
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
    let fields = fields::make_fields(names.into_iter().zip(values).collect());
    let mut mesh = Mesh::new(src, positions, tets, fields)?;
    mesh.field_data = field_data;
    fields::select_active(
        &mut mesh,
        src,
        opts.scalar.as_deref(),
        pieces[0].scalars.as_deref(),
    )?;
    Ok(mesh)
}
