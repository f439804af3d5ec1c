//! The client report (docs/ROOM_FILE.md, "Design numbers"): one self-contained HTML file with
//! the views, the calculation surfaces against their targets, the glare table, the luminaire
//! schedule, the maintenance factor and the accuracy settings used. It takes its images and
//! numbers as inputs; [`build`] gathers them from a session.

pub mod base64;
pub mod build;
pub mod html;

pub use build::{ReportOptions, report_html};
pub use html::{ReportImage, ReportInput, html};
