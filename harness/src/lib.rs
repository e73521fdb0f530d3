//! The `tetbench` harness as a library. Layers, each using only those above it:
//!
//! - `stats`, `table` (numbers and paper tables), `rows` (measured rows and their CSV),
//!   `meshes` (where meshes come from), `progress`, `sysinfo`;
//! - `measure` (the one frame-timing loop), `plots`, `experiment` (experiment files);
//! - `bench` (running an experiment, with `sweep` and `merge` for its shards), `peers` (peer
//!   declarations registered for a command, and the conformance suite);
//! - `report` (image figures and the HTML report, from what `bench` kept);
//! - `papers` (the papers' tables, one file per paper, each an experiment measured by `bench`),
//!   `reproduce` (the loop over them); `cli` (clap, turned into the plain types above) and
//!   `commands` (the subcommands), which nothing else uses.

pub mod bench;
pub mod cli;
pub mod commands;
pub mod experiment;
pub mod measure;
pub mod merge;
pub mod meshes;
pub mod papers;
pub mod peers;
pub mod plots;
pub mod progress;
pub mod report;
pub mod reproduce;
pub mod rows;
pub mod stats;
pub mod sweep;
pub mod sysinfo;
pub mod table;
