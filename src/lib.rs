//! `reflect` as a library: the code of the `reflect` commands ([`cli`]) and of the verifier of the paper
//! ([`verify`]), so that the binary (`src/main.rs`), the integration tests and the Python package run one
//! implementation. The rendering and SH mathematics live in the `renderer` and `analysis` crates.

pub mod bench;
pub mod cli;
pub mod images;
pub mod verify;
