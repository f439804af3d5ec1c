//! A horizontal work-plane calculation grid (`haiko grid`) and illuminance statistics.

use glam::DVec3;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::transport::direct::Receiver;

/// The most points a work-plane grid may have (4 million).
pub const MAX_POINTS: usize = 4_000_000;

/// The smallest spacing, m (rounded up to the millimetre), whose grid over a `w × d` m area
/// has at most [`MAX_POINTS`] points: the positive root of `(w/S + 1)(d/S + 1) = N`.
fn min_spacing(w: f64, d: f64) -> f64 {
    let n = MAX_POINTS as f64;
    // (w/S + 1)(d/S + 1) ≤ N  ⇔  (N − 1)S² − (w + d)S − wd ≥ 0.
    let s = ((w + d) + ((w + d).powi(2) + 4.0 * (n - 1.0) * w * d).sqrt()) / (2.0 * (n - 1.0));
    (s * 1e3).ceil() / 1e3
}

/// A work-plane grid: points facing up at one height, spaced evenly and centred in the room.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct WorkPlane {
    /// Height above the floor, m.
    pub height_m: f64,
    /// Spacing between points along x and y, m.
    pub spacing_m: f64,
    /// Minimum distance from the walls, m.
    pub margin_m: f64,
    /// Points along x and y.
    pub counts: [usize; 2],
    /// Points that fell inside furniture and were left out.
    pub skipped_in_boxes: usize,
    /// The receivers (normal +z), row by row (x fastest).
    pub receivers: Vec<Receiver>,
}

impl WorkPlane {
    /// Lays the grid out over the room: along each axis `n = floor((L − 2M)/S) + 1` points,
    /// centred, so the margin to both walls is equal and at least `M`. Points strictly inside a
    /// box are skipped (a work plane does not run through a cabinet).
    pub fn new(scene: &Scene, height_m: f64, spacing_m: f64, margin_m: f64) -> Result<Self> {
        let size = scene.room_size;
        if !(height_m > 0.0 && height_m < size.z) {
            return Err(Error::input(
                "--height",
                "",
                format!("{height_m:?} m is not inside the room (0 to {:?} m)", size.z),
            ));
        }
        if !(spacing_m > 0.0 && spacing_m.is_finite()) {
            return Err(Error::input(
                "--spacing",
                "",
                format!("{spacing_m:?} m must be a positive number"),
            ));
        }
        if !(margin_m >= 0.0 && 2.0 * margin_m < size.x.min(size.y)) {
            return Err(Error::input(
                "--margin",
                "",
                format!("{margin_m:?} m leaves no room for a grid"),
            ));
        }
        // Counted in f64 (a spacing of 1e-9 m gives 4e9 points per axis; their product would
        // wrap a usize) and checked before anything is allocated.
        let count = |len: f64| ((len - 2.0 * margin_m) / spacing_m + 1e-9).floor() + 1.0;
        let (nx, ny) = (count(size.x), count(size.y));
        let points = nx * ny;
        if points.is_nan() || points > MAX_POINTS as f64 {
            return Err(Error::input(
                "--spacing",
                "",
                format!(
                    "{spacing_m:?} m gives {:.3e} points, more than {MAX_POINTS}: choose a spacing of at least {:.3} m",
                    points,
                    min_spacing(size.x - 2.0 * margin_m, size.y - 2.0 * margin_m)
                ),
            ));
        }
        let counts = [nx as usize, ny as usize];
        let start = |len: f64, n: usize| (len - (n - 1) as f64 * spacing_m) / 2.0;
        let (x0, y0) = (start(size.x, counts[0]), start(size.y, counts[1]));
        let mut receivers = Vec::with_capacity(counts[0] * counts[1]);
        let mut skipped_in_boxes = 0;
        for j in 0..counts[1] {
            for i in 0..counts[0] {
                let point = DVec3::new(x0 + i as f64 * spacing_m, y0 + j as f64 * spacing_m, height_m);
                if scene
                    .boxes
                    .iter()
                    .chain(&scene.mesh_bounds)
                    .any(|b| b.contains_strictly(point))
                {
                    skipped_in_boxes += 1;
                } else {
                    receivers.push(Receiver {
                        point,
                        normal: DVec3::Z,
                    });
                }
            }
        }
        Ok(WorkPlane {
            height_m,
            spacing_m,
            margin_m,
            counts,
            skipped_in_boxes,
            receivers,
        })
    }
}

/// Illuminance statistics over a grid (lx); `u0 = E_min / E_avg` (0 when E_avg is 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(crate) struct GridStats {
    /// Mean illuminance, lx.
    pub e_avg: f64,
    /// Minimum, lx.
    pub e_min: f64,
    /// Maximum, lx.
    pub e_max: f64,
    /// Uniformity E_min / E_avg.
    pub u0: f64,
    /// Number of points.
    pub points: usize,
}

impl GridStats {
    /// Statistics of a non-empty list of illuminances.
    pub fn of(lux: &[f64]) -> Self {
        let e_avg = lux.iter().sum::<f64>() / lux.len() as f64;
        let e_min = lux.iter().copied().fold(f64::INFINITY, f64::min);
        let e_max = lux.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let u0 = if e_avg > 0.0 { e_min / e_avg } else { 0.0 };
        GridStats {
            e_avg,
            e_min,
            e_max,
            u0,
            points: lux.len(),
        }
    }
}
