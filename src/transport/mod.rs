//! Light transport: the effect plan, direct light, visibility, interreflection, the bake cache.

pub mod bake;
pub mod basis;
pub mod cache;
pub mod direct;
pub mod formfactor;
pub mod gather;
pub mod interpolate;
pub mod occlusion;
pub mod plan;
pub mod radiosity;
pub mod visibility;
