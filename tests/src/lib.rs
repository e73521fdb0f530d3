//! The workspace's integration tests (`tests/tests/`: one binary per subject: io, sorts,
//! renderers, gpu) and what they share ([`test_util`]).

pub mod test_util;
