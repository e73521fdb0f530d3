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

/// Builds the process-wide state renderers share, so that a measured `prepare` does not pay for
/// it: rayon's thread pool, the shared Ψ table (`optics::PsiTable::shared`) and, when
/// `renderer` runs on a GPU, the GPU context (`gpu::Gpu::shared`; a missing GPU is left for
/// the renderer's own `prepare` to report). These are fixed costs, independent of the mesh and
/// of which renderer came first; CONVENTIONS §7 reports them apart ([`shared_state_bytes`]).
pub fn warm_process_state(renderer: &str) {
    rayon::broadcast(|_| ());
    let _ = optics::PsiTable::shared();
    if render::info(renderer).is_ok_and(|i| i.needs_gpu) {
        let _ = gpu::Gpu::shared();
    }
}

/// The heap bytes of the process-wide state [`warm_process_state`] builds: the shared Ψ table.
/// (The GPU context's host memory is wgpu's and the driver's, and is not reported.) Asking
/// does not build anything.
pub fn shared_state_bytes() -> usize {
    optics::PsiTable::heap_bytes(optics::PsiTable::DEFAULT_SIZE)
}
