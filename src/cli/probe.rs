//! `haiko probe ROOM --points FILE.csv`: illuminance at given receivers, through the session.

use std::fmt::Write as _;
use std::path::Path;

use crate::cli::{load_room, open_session};
use crate::error::{Result, check_finite};
use crate::scene::DirectMode;
use crate::scene::points::{POINTS_HEADER, read_points};
use crate::session::budget::MemoryLimit;
use crate::transport::direct::Receiver;

/// Formats receivers and their illuminance as CSV (`x,y,z,nx,ny,nz,lux`), in input order.
pub(crate) fn format_csv(receivers: &[Receiver], lux: &[f64]) -> String {
    let mut out = format!("{POINTS_HEADER},lux\n");
    for (rx, e) in receivers.iter().zip(lux) {
        let (p, n) = (rx.point, rx.normal);
        let _ = writeln!(out, "{},{},{},{},{},{},{:.6}", p.x, p.y, p.z, n.x, n.y, n.z, e);
    }
    out
}

/// Runs the command: prints the CSV on standard output.
pub fn run(
    room: &Path,
    points: &Path,
    direct_only: bool,
    mode: DirectMode,
    limit: &MemoryLimit,
) -> Result<()> {
    let scene = load_room(room)?;
    let receivers = read_points(points, scene.room_size)?;
    let mut session = open_session(scene, !direct_only, limit)?;
    let lux = session.illuminance_at(&receivers, direct_only, mode)?;
    check_finite("probe: an illuminance", lux.iter().copied())?;
    print!("{}", format_csv(&receivers, &lux));
    Ok(())
}
