//! Side studies of the BCC paper (CC against BCC lattices at equal information): the
//! lattice description that travels with `datasets-gen`'s lattice meshes, and ray casting of
//! regular CC and BCC volumes with the paper's reconstruction schemes.

pub mod lattice;
pub mod recon;
