//! Visibility between two points of the scene (shadow rays).

use glam::DVec3;

/// Answers whether the open segment between two points is free of occluders.
/// Implementations are shared across threads.
pub trait Visibility: Sync {
    /// True when nothing blocks the segment `from → to` (end points excluded, so points on
    /// surfaces see each other).
    fn visible(&self, from: DVec3, to: DVec3) -> bool;
}

/// The empty convex room: everything sees everything.
#[derive(Debug, Clone, Copy, Default)]
pub struct Unoccluded;

impl Visibility for Unoccluded {
    fn visible(&self, _from: DVec3, _to: DVec3) -> bool {
        true
    }
}
