//! Reading and writing meshes and transfer functions, one module per part.

mod roundtrip;
mod text_encodings;
mod transfer_functions;
