//! The reader on hand-written files of every layout, on broken ones, and fuzzed.

use glam::DVec3;

use super::*;
use crate::io::{LoadOptions, Split};
use crate::Error;

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
