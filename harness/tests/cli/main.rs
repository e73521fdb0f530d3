//! The `tetbench` command line end to end, one module per part: its commands' outputs and
//! exit codes, `convert`'s round trips, inputs that must not block or abort it, and the
//! experiment TOML against hostile text.

#[path = "../test_util/mod.rs"]
mod test_util;

mod commands;
mod convert;
mod experiment_fuzz;
mod hostile_inputs;
