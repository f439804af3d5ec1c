//! Design numbers (docs/ROOM_FILE.md, "Design numbers"): calculation grids laid out by
//! EN 12464-1 (and the plain work-plane grid of `haiko grid`), maintained illuminance statistics
//! against targets, the CIE 117 glare rating at observers, and the luminaire schedule. It lays out
//! receivers and turns their illuminance — computed by the session (docs/ARCHITECTURE.md,
//! "Numbers") — into statistics; it sits above [`crate::transport`] and below the session.

pub mod evaluate;
pub mod glare;
pub mod grid;
pub mod schedule;
pub mod stats;
pub mod work_plane;

pub use evaluate::{
    SurfaceResult, SurfaceSummary, eye_receivers, glare_with, surface_grids, surface_results,
};
pub use glare::{GlareSource, ObserverGlare, SourceGlare, SourceStatus, UgrStatus, observer_glare};
pub use grid::{CalcGrid, GridIndex, GridPart};
pub use schedule::{ScheduleRow, luminaire_schedule};
pub use stats::{Check, SurfaceCheck, SurfaceStats};
