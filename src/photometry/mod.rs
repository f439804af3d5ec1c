//! What a luminaire emits: intensity curves, their Legendre / spherical-harmonic series,
//! truncation and ringing control, aiming, and IES LM-63 / EULUMDAT files.

pub mod aim;
pub mod curve;
pub mod edit;
pub mod emission;
pub mod gauss;
pub mod ies;
pub mod ldt;
pub mod legendre;
pub mod lidfile;
pub mod lookup;
pub mod luminous;
pub mod sh;
pub mod truncation;
pub mod weights;

pub use aim::{aimed_coefficients, eval_aimed};
pub use curve::{Curve, CurveError, MAX_INTENSITY_CD};
pub use edit::IncrementalWeights;
pub use emission::{LightState, coefficients_from_weights, light_coefficients};
pub use ies::{parse_ies, write_ies, write_ies_with_area};
pub use ldt::parse_ldt;
pub use legendre::{legendre_series, legendre_table};
pub use lidfile::{ASYMMETRY_WARNING, CSpread, LidFile, LidFormat, parse_lid_bytes, read_lid_file};
pub use luminous::{HorizontalAxis, LuminousShape};
pub use sh::{ShBasis, sh_count, sh_index};
pub use truncation::{TruncationStats, Window, auto_window, choose_order, truncation_stats};
pub use weights::{HatMoments, ZonalWeights};
