//! The GPU renderers and sorts, one module per part: on lavapipe in CI, where
//! `TETBENCH_REQUIRE_GPU=1` makes a missing adapter a failure.

mod edge_on_faces;
mod hapt;
mod ptint;
mod sort;
mod xmpvo;
