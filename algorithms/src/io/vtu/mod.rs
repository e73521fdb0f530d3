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
//! A file's raw appended arrays of tets are read as a stream, with a peak of the mesh and a
//! block.
//!
//! The writer is [`crate::io::writers::vtu`].
//!
//! Files: [`stream`] reads a file (a large all-tet mesh of raw appended arrays a block at a
//! time, straight into the mesh), [`read`] parses the XML and makes the mesh of a file held in
//! memory, [`data`] decodes one DataArray (ASCII, base64, zlib, appended).

mod data;
mod read;
mod stream;
#[cfg(test)]
pub(crate) mod tests;

pub use read::parse_vtu;
pub use stream::read_vtu;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Section {
    Points,
    Cells,
    PointData,
    CellData,
    FieldData,
    Other,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Format {
    Ascii,
    Binary,
    Appended,
}

#[derive(Debug)]
pub(super) struct Array {
    pub(super) name: String,
    pub(super) ty: String,
    pub(super) ncomp: usize,
    pub(super) ntuples: Option<usize>,
    pub(super) format: Format,
    pub(super) offset: usize,
    pub(super) text: String,
    pub(super) pos: usize,
    pub(super) section: Section,
}

#[derive(Debug, Default)]
pub(super) struct Piece {
    pub(super) npts: usize,
    pub(super) ncells: usize,
    pub(super) scalars: Option<String>,
    pub(super) arrays: Vec<Array>,
}
