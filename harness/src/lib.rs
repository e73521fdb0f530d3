//! The `tetbench` harness as a library: the CLI definitions and the commands behind them.

pub mod cli;
pub mod commands;
pub mod jbu;
