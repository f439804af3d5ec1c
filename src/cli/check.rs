//! `haiko check ROOM`: every calculation surface's maintained Ē, E_min, E_max, U0 and g2
//! against its targets, pass or fail, from the session's design numbers
//! ([`crate::session::Session::design_numbers`]) — the same illuminance as `haiko probe` at the
//! same points. As text tables or, with `--json`, one JSON document that also lists every
//! point's new illuminance.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::cli::{load_room, open_session};
use crate::error::{Error, Result};
use crate::metrics::{Check, SurfaceResult, SurfaceSummary};
use crate::session::DesignNumbers;
use crate::session::budget::MemoryLimit;

/// One grid point in the JSON: where it is, which way it faces, its new illuminance.
#[derive(Serialize)]
struct PointJson {
    point: [f64; 3],
    normal: [f64; 3],
    /// New illuminance, lx (what `haiko probe` prints for this point).
    lux: f64,
}

#[derive(Serialize)]
struct SurfaceJson<'a> {
    #[serde(flatten)]
    summary: SurfaceSummary<'a>,
    points_lux: Vec<PointJson>,
}

#[derive(Serialize)]
struct CheckJson<'a> {
    room: String,
    maintenance_factor: f64,
    direct_only: bool,
    /// All surfaces with targets pass (`None` without any target).
    pass: Option<bool>,
    surfaces: Vec<SurfaceJson<'a>>,
}

/// `Some(true)` when every judged result passes, `Some(false)` when one fails, `None` when
/// nothing is judged.
pub(crate) fn overall(verdicts: impl IntoIterator<Item = Option<bool>>) -> Option<bool> {
    verdicts
        .into_iter()
        .flatten()
        .fold(None, |all, v| Some(all.unwrap_or(true) && v))
}

/// The numbers as one pretty-printed JSON document.
pub fn to_json(
    room: &str,
    maintenance_factor: f64,
    direct_only: bool,
    surfaces: &[SurfaceResult],
) -> Result<String> {
    let doc = CheckJson {
        room: room.to_string(),
        maintenance_factor,
        direct_only,
        pass: overall(surfaces.iter().map(|s| s.summary().pass)),
        surfaces: surfaces
            .iter()
            .map(|s| SurfaceJson {
                summary: s.summary(),
                points_lux: s
                    .grid
                    .receivers
                    .iter()
                    .zip(&s.lux)
                    .map(|(r, &lux)| PointJson {
                        point: r.point.to_array(),
                        normal: r.normal.to_array(),
                        lux,
                    })
                    .collect(),
            })
            .collect(),
    };
    serde_json::to_string_pretty(&doc).map_err(|e| Error::internal(format!("check: JSON: {e}")))
}

/// `value` (with `digits` decimals) and its pass/fail mark, and the target as `≥ t`.
fn judged(check: &Check, digits: usize) -> (String, String) {
    let value = format!("{:.digits$} {}", check.value, check.mark());
    let target = check
        .target
        .map_or("–".to_string(), |t| format!("≥ {t:.digits$}"));
    (value.trim_end().to_string(), target)
}

/// The numbers as a text table, one row per surface, and a last line with the verdict.
pub(crate) fn to_text(
    room: &str,
    maintenance_factor: f64,
    direct_only: bool,
    surfaces: &[SurfaceResult],
) -> String {
    let mut out = format!(
        "{room}: maintenance factor {maintenance_factor:.2} (maintained = new × factor){}\n",
        if direct_only { ", direct light only" } else { "" }
    );
    let _ = writeln!(
        out,
        "{:<20} {:>6}  {:>9} {:>7}  {:>7} {:>7}  {:>6} {:>6}  {:>6} {:>6}  result",
        "surface", "points", "Ē_m lx", "target", "E_min", "E_max", "U0", "target", "g2", "target"
    );
    for s in surfaces {
        let summary = s.summary();
        let name: String = summary.name.chars().take(20).collect();
        let (Some(stats), Some(check)) = (s.stats, s.check) else {
            let _ = writeln!(out, "{name:<20} {:>6}  every point lies under furniture", 0);
            continue;
        };
        let (e, e_target) = judged(&check.e_avg, 0);
        let (u0, u0_target) = judged(&check.u0, 2);
        let (g2, g2_target) = judged(&check.g2, 2);
        let verdict = match summary.pass {
            Some(true) => "pass",
            Some(false) => "FAIL",
            None => "no target",
        };
        let _ = writeln!(
            out,
            "{name:<20} {:>6}  {e:>9} {e_target:>7}  {:>7.0} {:>7.0}  {u0:>6} {u0_target:>6}  {g2:>6} {g2_target:>6}  {verdict}",
            stats.points, stats.e_min, stats.e_max
        );
    }
    let verdict = match overall(surfaces.iter().map(|s| s.summary().pass)) {
        Some(true) => "every target met",
        Some(false) => "some targets missed",
        None => "no targets to judge",
    };
    let _ = writeln!(out, "{verdict}");
    out
}

/// Runs the command: loads the room, opens a session (the user's bake cache unless
/// `direct_only`) and prints the surfaces' numbers.
pub fn run(room: &Path, json: bool, direct_only: bool, limit: &MemoryLimit) -> Result<()> {
    let scene = load_room(room)?;
    let maintenance_factor = scene.design.maintenance_factor;
    let mut session = open_session(scene, !direct_only, limit)?;
    let DesignNumbers { surfaces, .. } = session.design_numbers();
    let name = room.display().to_string();
    if json {
        println!("{}", to_json(&name, maintenance_factor, direct_only, &surfaces)?);
    } else {
        print!("{}", to_text(&name, maintenance_factor, direct_only, &surfaces));
    }
    Ok(())
}
