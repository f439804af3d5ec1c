//! `haiko probe ROOM --points FILE.csv`: illuminance at given receivers.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{Error, Result};
use crate::scene::{self, DirectMode, Scene};
use crate::transport::direct::Receiver;
use crate::transport::gather::illuminance_at_receivers;

use crate::scene::points::POINTS_HEADER;

/// Formats receivers and their illuminance as CSV (`x,y,z,nx,ny,nz,lux`), in input order.
pub fn format_csv(receivers: &[Receiver], lux: &[f64]) -> String {
    let mut out = format!("{POINTS_HEADER},lux\n");
    for (rx, e) in receivers.iter().zip(lux) {
        let (p, n) = (rx.point, rx.normal);
        let _ = writeln!(out, "{},{},{},{},{},{},{:.6}", p.x, p.y, p.z, n.x, n.y, n.z, e);
    }
    out
}

/// Illuminance (lx) at receivers for the command line: direct only, or direct plus gathered
/// indirect light from the bake (loaded from the cache or baked, with progress on stderr).
pub fn lux_at(
    scene: &Scene,
    receivers: &[Receiver],
    direct_only: bool,
    mode: DirectMode,
) -> Result<Vec<f64>> {
    if direct_only {
        if mode == DirectMode::Basis {
            return Err(Error::input(
                "--mode",
                "",
                "basis mode needs the bake: drop --direct-only",
            ));
        }
        return Ok(illuminance_at_receivers(
            scene,
            None,
            DirectMode::Exact,
            receivers,
        ));
    }
    let bake = crate::cli::bake::bake_for_cli(scene)?;
    Ok(illuminance_at_receivers(scene, Some(&bake), mode, receivers))
}

/// Runs the command: prints the CSV on standard output.
pub fn run(room: &Path, points: &Path, direct_only: bool, mode: DirectMode) -> Result<()> {
    let scene = scene::load(room)?;
    let receivers: Vec<Receiver> = scene::points::read_points(points)?
        .into_iter()
        .map(|p| Receiver {
            point: p.point,
            normal: p.normal,
        })
        .collect();
    let lux = lux_at(&scene, &receivers, direct_only, mode)?;
    print!("{}", format_csv(&receivers, &lux));
    Ok(())
}
