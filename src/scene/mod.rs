//! The scene: room file (TOML, version 1), OBJ meshes, meshing into fine and coarse patches.

pub mod model;

pub use model::*;
