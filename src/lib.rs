//! Haiko: a terminal editor for interior lighting design, and the library under it.
//!
//! Data flows one way (docs/ARCHITECTURE.md): [`scene`] (room file, meshes) → [`transport`]
//! (plan, direct light, bake with interreflection) → [`relight`] (the per-edit blend) and
//! [`render`] (rasteriser, ID buffer, picking) → [`session`] (one engine for every command and
//! the editor) → the command line and the terminal editor. [`photometry`] owns the luminous
//! intensity curves, their files and their spherical-harmonic series; [`metrics`] and
//! [`accuracy`] turn the lit room into design numbers and error-versus-time tables.
//!
//! The terminal editor and the command line sit behind the default feature `cli`; with
//! `default-features = false` the library builds without ratatui, crossterm and clap
//! (docs/ARCHITECTURE.md, "Library").
//!
//! # Example: a photometric file's flux and its spherical-harmonic weights
//!
//! A Lambertian downlight, I(γ) = 1000 cd · cos γ, as an IES (LM-63-2002) text. Its flux is
//! π · 1000 lm, and its zonal weights are 1000 cd · (1/4, 1/2, 5/16, …) — less the small chord
//! error of the file's 10° steps, which the piecewise-linear curve between them carries.
//!
//! ```
//! use std::path::Path;
//!
//! use haiko::photometry::{ZonalWeights, parse_ies};
//!
//! let text = "IESNA:LM-63-2002
//! TILT=NONE
//! 1 -1 1 10 1 1 2 0 0 0
//! 1 1 10
//! 0 10 20 30 40 50 60 70 80 90
//! 0
//! 1000 984.81 939.69 866.03 766.04 642.79 500 342.02 173.65 0
//! ";
//! let file = parse_ies(Path::new("downlight.ies"), text)?;
//! let flux = file.curve.flux_lm();
//! let weights = ZonalWeights::exact(&file.curve, 4);
//! println!("flux {flux:.1} lm; w0..w2 {:.1?} cd", &weights.w[..3]);
//!
//! assert!((flux / (std::f64::consts::PI * 1000.0) - 1.0).abs() < 0.01);
//! assert!((weights.flux_lm() - flux).abs() < 1e-9 * flux);
//! for (w, exact) in weights.w.iter().zip([250.0, 500.0, 312.5]) {
//!     assert!((w / exact - 1.0).abs() < 0.01, "{w} vs {exact}");
//! }
//! # Ok::<(), haiko::Error>(())
//! ```

pub mod accuracy;
/// The command line: the binary's front end, not a library API (hidden from the docs).
#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod cli;
pub mod error;
pub mod fsio;
pub mod heap;
pub mod metrics;
pub mod photometry;
pub mod relight;
pub mod render;
pub mod report;
pub mod scene;
pub mod session;
pub mod transport;
/// The terminal editor: the binary's front end, public for its tests, not a library API.
#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod tui;

pub use error::{Error, Result};
