//! The reader on every encoding, on broken and hostile files, round trips through the writer,
//! and fuzzed.

use std::fmt::Write as _;
use std::io::Write;

use base64::Engine;
use glam::DVec3;

use super::data::B64;
use super::read::find;
use super::*;
use crate::error::Error;
use crate::io::write_vtu;
use crate::io::{LoadOptions, Split};
use crate::mesh::{Field, Mesh};

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
            let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
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
