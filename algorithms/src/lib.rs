//! tetbench algorithms: the mesh model and its loaders, the camera, transfer functions and optics,
//! visibility sorts and the renderers, shared by the `tetbench` harness and `datasets-gen`.

pub mod alloc;
pub mod bcc_recon;
pub mod camera;
pub mod error;
pub mod gpu;
pub mod image;
pub mod io;
pub mod jbu;
pub mod lattice;
pub mod mesh;
pub mod metrics;
pub mod optics;
pub mod optics_f32;
pub mod plugin;
pub mod pt;
pub mod render;
pub mod schedule;
pub mod sort;
pub mod tf;

pub use error::{Error, Result};
pub use glam;
pub use mesh::Mesh;
pub use tf::TransferFunction;
