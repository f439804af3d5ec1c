//! `haiko grid ROOM --height H --spacing S`: a horizontal work-plane grid
//! ([`crate::metrics::work_plane`]) lit through the session, as text or JSON.

use std::path::Path;

use serde::Serialize;

use crate::cli::{load_room, open_session};
use crate::error::{Error, Result, check_finite, printable};
use crate::metrics::work_plane::{GridStats, WorkPlane};
use crate::scene::DirectMode;
use crate::session::budget::MemoryLimit;

#[derive(Serialize)]
struct GridPoint {
    x: f64,
    y: f64,
    z: f64,
    lux: f64,
}

#[derive(Serialize)]
struct GridJson<'a> {
    room: String,
    height_m: f64,
    spacing_m: f64,
    margin_m: f64,
    direct_only: bool,
    #[serde(flatten)]
    stats: &'a GridStats,
    skipped_in_boxes: usize,
    grid: Vec<GridPoint>,
}

/// Runs the command.
pub fn run(
    room: &Path,
    height_m: f64,
    spacing_m: f64,
    margin_m: Option<f64>,
    json: bool,
    direct_only: bool,
    limit: &MemoryLimit,
) -> Result<()> {
    let scene = load_room(room)?;
    let margin_m = match margin_m {
        Some(margin_m) => margin_m,
        None => {
            // The default margin is half the spacing: too wide a spacing leaves no room, and it
            // is the spacing the user wrote.
            let narrowest = scene.room_size.x.min(scene.room_size.y);
            if spacing_m.is_finite() && spacing_m >= narrowest {
                return Err(Error::input(
                    "--spacing",
                    "",
                    format!(
                        "{spacing_m:?} m is not below the room's narrowest side ({narrowest:?} m), so \
                         its default margin (half the spacing) leaves no room for a grid"
                    ),
                ));
            }
            spacing_m / 2.0
        }
    };
    let plane = WorkPlane::new(&scene, height_m, spacing_m, margin_m)?;
    if plane.receivers.is_empty() {
        return Err(Error::input(room, "", "every grid point lies inside furniture"));
    }
    let mut session = open_session(scene, !direct_only, limit)?;
    let lux = session.illuminance_at(&plane.receivers, direct_only, DirectMode::Exact)?;
    check_finite("grid: an illuminance", lux.iter().copied())?;
    let stats = GridStats::of(&lux);
    check_finite(
        "grid: a statistic",
        [stats.e_avg, stats.e_min, stats.e_max, stats.u0],
    )?;
    if json {
        let doc = GridJson {
            room: room.display().to_string(),
            height_m,
            spacing_m,
            margin_m: plane.margin_m,
            direct_only,
            stats: &stats,
            skipped_in_boxes: plane.skipped_in_boxes,
            grid: plane
                .receivers
                .iter()
                .zip(&lux)
                .map(|(r, &lux)| GridPoint {
                    x: r.point.x,
                    y: r.point.y,
                    z: r.point.z,
                    lux,
                })
                .collect(),
        };
        let text = serde_json::to_string_pretty(&doc).map_err(|e| Error::internal(e.to_string()))?;
        println!("{text}");
    } else {
        println!(
            "{}: work plane at {:.2} m, spacing {:.3} m, margin {:.3} m: {} × {} points{}{}",
            printable(&room.display().to_string()),
            height_m,
            spacing_m,
            plane.margin_m,
            plane.counts[0],
            plane.counts[1],
            if plane.skipped_in_boxes > 0 {
                format!(" ({} inside furniture left out)", plane.skipped_in_boxes)
            } else {
                String::new()
            },
            if direct_only { ", direct light only" } else { "" },
        );
        println!(
            "E_avg {:.1} lx   E_min {:.1} lx   E_max {:.1} lx   U0 {:.3}   ({} points)",
            stats.e_avg, stats.e_min, stats.e_max, stats.u0, stats.points
        );
    }
    Ok(())
}
