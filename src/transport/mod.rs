//! Light transport: the effect plan, direct light, visibility, interreflection, the bake cache.

pub mod bake;
pub mod basis;
pub mod box_bvh;
pub mod cache;
pub mod direct;
pub mod formfactor;
pub mod gather;
pub mod hierarchy;
pub mod indirect;
pub mod interpolate;
pub mod interreflection;
pub mod links;
mod mesh_contacts;
mod mesh_on_mesh;
pub mod occlusion;
pub mod patchdirect;
pub mod plan;
pub mod radiosity;
pub mod refine;
pub mod response;
pub mod room_edges;
pub mod sh_response;
pub mod slopes;
pub mod visibility;
