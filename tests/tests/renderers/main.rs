//! The renderers, one module per part: each against the reference (every registered one in
//! `registry`), pinned images, and the JBU wrapper.

mod cpu_pt;
mod jbu;
mod raycast;
mod raycast_bits;
mod reference;
mod registry;
mod tet_raster;
mod volume_raycast;
mod vtk_peers;
mod watertight;
