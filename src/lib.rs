//! Haiko: a terminal editor for interior lighting design, and the library under it.
//!
//! Data flows one way (docs/ARCHITECTURE.md): [`scene`] (room file, meshes) → [`transport`]
//! (plan, direct light, bake with interreflection) → [`relight`] (the per-edit blend) and
//! [`render`] (rasteriser, ID buffer, picking) → [`session`] (one engine for every command and
//! the editor) → the command line and the terminal editor. [`photometry`] owns the luminous
//! intensity curves, their files and their spherical-harmonic series; [`metrics`] and
//! [`accuracy`] turn the lit room into design numbers and error-versus-time tables.

pub mod accuracy;
#[cfg(feature = "cli")]
pub mod cli;
pub mod error;
pub mod metrics;
pub mod photometry;
pub mod relight;
pub mod render;
pub mod report;
pub mod scene;
pub mod session;
pub mod transport;
#[cfg(feature = "cli")]
pub mod tui;

pub use error::{Error, Result};
