//! Haiko: a terminal editor for interior lighting design.
//!
//! Data flows one way (docs/ARCHITECTURE.md): [`scene`] → [`transport`] (plan, bake) → [`relight`] →
//! [`render`] → the terminal UI or a PNG. [`photometry`] owns the luminous intensity curves and
//! their spherical-harmonic series.

pub mod cli;
pub mod error;
pub mod fsio;
pub mod photometry;
pub mod relight;
pub mod render;
pub mod scene;
pub mod transport;
pub mod tui;

pub use error::{Error, Result};
