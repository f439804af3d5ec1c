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

/// The visible fraction of a patch from shadow rays `(weight, unblocked)` to points spread over
/// it (a grid on a leaf; on a cluster one point per sub-cluster, whose areas differ, which this
/// does not weigh), each weighted by the form-factor kernel at its point
/// ([`crate::transport::formfactor::kernel`]): the patch's exact unoccluded form factor times this
/// fraction is its occluded one up to the spread's resolution. An unweighted fraction is biased
/// where visibility follows the kernel — a ceiling seen through a slot behind a sideboard shows
/// only its grazing part (docs/DECISIONS.md "Shadow rays weighted by the kernel"). The unweighted
/// fraction when every weight is zero; 1 without rays.
pub fn weighted_fraction(rays: impl Iterator<Item = (f64, bool)>) -> f64 {
    let (mut seen, mut total, mut seen_count, mut count) = (0.0, 0.0, 0usize, 0usize);
    for (weight, unblocked) in rays {
        total += weight;
        count += 1;
        if unblocked {
            seen += weight;
            seen_count += 1;
        }
    }
    if total > 0.0 {
        seen / total
    } else if count > 0 {
        seen_count as f64 / count as f64
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rays weigh by their kernel: a patch whose visible part holds three quarters of the kernel
    /// is three quarters visible, whatever share of its rays see it; all weights zero fall back
    /// to the share of rays; no rays see everything.
    #[test]
    fn weighted_fraction_weighs_rays_by_their_kernel() {
        let rays = [(3.0, true), (0.5, false), (0.25, false), (0.25, false)];
        assert_eq!(weighted_fraction(rays.into_iter()), 0.75);
        let unweighted = [(0.0, true), (0.0, false), (0.0, false), (0.0, true)];
        assert_eq!(weighted_fraction(unweighted.into_iter()), 0.5);
        assert_eq!(weighted_fraction(std::iter::empty()), 1.0);
        assert_eq!(weighted_fraction([(1.0, false); 4].into_iter()), 0.0);
    }
}
