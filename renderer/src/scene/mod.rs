//! Scenes: the TOML file format of CONVENTIONS §6 ([`file`](mod@file)) and the runtime scene built from it
//! ([`build`]).

pub mod build;
pub mod file;

pub use build::{RenderSettings, Scene};
pub use file::SceneFile;
