//! The `tetbench` harness as a library: the CLI definitions and the commands behind them.

pub mod bcc;
pub mod bench;
pub mod cli;
pub mod commands;
pub mod experiment;
pub mod jbu;
pub mod plots;
pub mod reproduce;
pub mod sysinfo;
