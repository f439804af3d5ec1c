//! What a luminaire emits: intensity curves, their Legendre / spherical-harmonic series,
//! truncation and ringing control, aiming, and IES LM-63 / EULUMDAT files.

pub mod curve;
pub mod gauss;
pub mod ies;
pub mod ldt;
pub mod lidfile;

pub use curve::{Curve, CurveError};
pub use ies::write_ies;
pub use lidfile::{LidFile, LidFormat, read_lid_file};
