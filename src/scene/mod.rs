//! The scene: room file (TOML, version 1), OBJ meshes, meshing into fine and coarse patches.

pub mod calc_spec;
pub mod design;
pub mod enclosure;
pub mod light_tables;
pub mod load;
pub mod mesher;
pub mod model;
pub mod obj;
pub mod points;
pub mod remesh;
pub mod room_file;
pub mod save;

pub use load::{RoomText, load, read_room};
pub use model::*;
