//! The harness's measurement pipeline end to end, one module per part: `bench` and `plot`,
//! sharded and resumed sweeps and the integrity of their rows, the paper tables, the HTML
//! report in a browser, and peers under supervision.

#[path = "../test_util/mod.rs"]
mod test_util;

mod bench;
mod paper_tables;
mod peers;
mod report;
mod sweep;
mod sweep_integrity;
