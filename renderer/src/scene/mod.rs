//! Scenes: the TOML file format of docs/src/conventions.md §6 ([`file`](mod@file)) and the runtime scene built from it
//! ([`build`]).

pub mod build;
/// The scene-file types, defined in `vocab` (docs/src/conventions.md §6).
pub use vocab::scene as file;

pub use build::{BuildTimings, RenderSettings, Scene};
pub use file::SceneFile;
