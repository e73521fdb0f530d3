//! The visibility sorts, one module per part.

mod bcc_implicit;
mod xmpvo;
