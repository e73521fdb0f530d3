//! VTK's type codes, which the `.vtk` and `.vtu` readers share: the cell types and the numeric
//! types of data arrays, with the decoding of their bytes in either byte order.

pub const VTK_TETRA: u8 = 10;
pub const VTK_VOXEL: u8 = 11;
pub const VTK_HEXAHEDRON: u8 = 12;
pub const VTK_WEDGE: u8 = 13;
pub const VTK_PYRAMID: u8 = 14;

/// Name of a VTK cell type id, for messages.
pub fn cell_type_name(t: i64) -> &'static str {
    match t {
        1 => "vertex",
        2 => "poly-vertex",
        3 => "line",
        4 => "poly-line",
        5 => "triangle",
        6 => "triangle strip",
        7 => "polygon",
        8 => "pixel",
        9 => "quad",
        10 => "tetra",
        11 => "voxel",
        12 => "hexahedron",
        13 => "wedge",
        14 => "pyramid",
        15 => "pentagonal prism",
        16 => "hexagonal prism",
        21..=33 => "quadratic cell",
        42 => "polyhedron",
        60..=80 => "higher-order cell",
        _ => "unknown",
    }
}

/// A VTK numeric type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl DType {
    pub fn size(self) -> usize {
        match self {
            DType::I8 | DType::U8 => 1,
            DType::I16 | DType::U16 => 2,
            DType::I32 | DType::U32 | DType::F32 => 4,
            DType::I64 | DType::U64 | DType::F64 => 8,
        }
    }
    pub fn is_float(self) -> bool {
        matches!(self, DType::F32 | DType::F64)
    }
    /// XML names (`Float32`, `Int64`, …).
    pub fn from_xml(s: &str) -> Option<DType> {
        Some(match s {
            "Int8" => DType::I8,
            "UInt8" => DType::U8,
            "Int16" => DType::I16,
            "UInt16" => DType::U16,
            "Int32" => DType::I32,
            "UInt32" => DType::U32,
            "Int64" => DType::I64,
            "UInt64" => DType::U64,
            "Float32" => DType::F32,
            "Float64" => DType::F64,
            _ => return None,
        })
    }
    /// Legacy names (`float`, `vtktypeint64`, …), case-insensitive.
    pub fn from_legacy(s: &str) -> Option<DType> {
        Some(match s.to_ascii_lowercase().as_str() {
            "char" | "signed_char" | "vtktypeint8" => DType::I8,
            "unsigned_char" | "vtktypeuint8" => DType::U8,
            "short" | "vtktypeint16" => DType::I16,
            "unsigned_short" | "vtktypeuint16" => DType::U16,
            "int" | "vtktypeint32" => DType::I32,
            "unsigned_int" | "vtktypeuint32" => DType::U32,
            "long" | "vtktypeint64" | "vtkidtype" | "long_long" => DType::I64,
            "unsigned_long" | "vtktypeuint64" | "unsigned_long_long" => DType::U64,
            "float" | "vtktypefloat32" => DType::F32,
            "double" | "vtktypefloat64" => DType::F64,
            _ => return None,
        })
    }
}

fn word<const N: usize>(b: &[u8], big: bool) -> [u8; N] {
    let mut w = [0u8; N];
    w.copy_from_slice(&b[..N]);
    if big {
        w.reverse();
    }
    w
}

/// Decodes `bytes` (a whole number of values) as f64.
pub fn decode_f64(bytes: &[u8], ty: DType, big: bool) -> Vec<f64> {
    let s = ty.size();
    bytes
        .chunks_exact(s)
        .map(|c| match ty {
            DType::I8 => c[0] as i8 as f64,
            DType::U8 => c[0] as f64,
            DType::I16 => i16::from_le_bytes(word(c, big)) as f64,
            DType::U16 => u16::from_le_bytes(word(c, big)) as f64,
            DType::I32 => i32::from_le_bytes(word(c, big)) as f64,
            DType::U32 => u32::from_le_bytes(word(c, big)) as f64,
            DType::I64 => i64::from_le_bytes(word(c, big)) as f64,
            DType::U64 => u64::from_le_bytes(word(c, big)) as f64,
            DType::F32 => f32::from_le_bytes(word(c, big)) as f64,
            DType::F64 => f64::from_le_bytes(word(c, big)),
        })
        .collect()
}

/// Decodes `bytes` as integers; float types and values past `i64::MAX` are refused.
pub fn decode_i64(bytes: &[u8], ty: DType, big: bool) -> std::result::Result<Vec<i64>, String> {
    if ty.is_float() {
        return Err(format!(
            "has a floating-point type ({ty:?}) where integers are needed"
        ));
    }
    let s = ty.size();
    bytes
        .chunks_exact(s)
        .map(|c| {
            Ok(match ty {
                DType::I8 => c[0] as i8 as i64,
                DType::U8 => c[0] as i64,
                DType::I16 => i16::from_le_bytes(word(c, big)) as i64,
                DType::U16 => u16::from_le_bytes(word(c, big)) as i64,
                DType::I32 => i32::from_le_bytes(word(c, big)) as i64,
                DType::U32 => u32::from_le_bytes(word(c, big)) as i64,
                DType::I64 => i64::from_le_bytes(word(c, big)),
                _ => {
                    let v = u64::from_le_bytes(word(c, big));
                    i64::try_from(v).map_err(|_| format!("integer {v} out of range"))?
                }
            })
        })
        .collect()
}
