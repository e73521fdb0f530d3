//! The renderers, one module per part: each against the reference (every registered one in
//! `registry`), pinned images, the JBU wrapper, and the exact integrator against
//! the model in 50-digit arithmetic (`exact_oracle`).

mod cpu_pt;
mod exact_oracle;
mod jbu;
mod raycast;
mod raycast_bits;
mod reference;
mod registry;
mod tet_raster;
mod volume_raycast;
mod vtk_peers;
mod watertight;
