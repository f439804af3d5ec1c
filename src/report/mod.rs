//! The client report (docs/ROOM_FILE.md, "Design numbers"): one self-contained HTML file with
//! the views, the calculation surfaces against their targets, the glare table, the luminaire
//! schedule, the maintenance factor and the accuracy settings used. It takes its images and
//! numbers as inputs; the session gathers them.

pub mod base64;
pub mod html;

pub use html::{ReportImage, ReportInput, html};
