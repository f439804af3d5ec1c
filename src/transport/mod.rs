//! Light transport: the effect plan, direct light, visibility, interreflection, the bake cache.

pub mod formfactor;
pub mod interpolate;
pub mod radiosity;
pub mod visibility;
