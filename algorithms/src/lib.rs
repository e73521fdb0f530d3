//! tetbench algorithms: the mesh model and its loaders, the camera, transfer functions and optics,
//! visibility sorts and the renderers, shared by the `tetbench` harness and `datasets-gen`.

pub mod bcc;
pub mod camera;
pub mod error;
pub mod gpu;
pub mod image;
pub mod io;
pub mod mesh;
pub mod metrics;
pub mod optics;
pub mod plugin;
pub mod render;
pub mod sort;
pub mod tf;
pub mod util;

pub use error::{Error, Result};
pub use glam;
pub use mesh::Mesh;
pub use tf::TransferFunction;
