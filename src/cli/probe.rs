//! `haiko probe ROOM --points FILE.csv`: illuminance at given receivers.

use std::fmt::Write as _;
use std::path::Path;

use glam::DVec3;

use crate::error::{Error, Result};
use crate::scene::{self, DirectMode, Scene};
use crate::transport::direct::Receiver;
use crate::transport::gather::illuminance_at_receivers;

/// The header the points file must start with.
pub const POINTS_HEADER: &str = "x,y,z,nx,ny,nz";

/// Parses a points CSV (`x,y,z,nx,ny,nz` per row, metres, world frame; normals are normalised).
pub fn parse_points(text: &str, file: &Path) -> Result<Vec<Receiver>> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(Error::input(
            file,
            "",
            format!("the points file is empty (expected the header `{POINTS_HEADER}`)"),
        ));
    };
    let header: String = header
        .trim_start_matches('\u{feff}')
        .split(',')
        .map(str::trim)
        .collect::<Vec<_>>()
        .join(",");
    if header != POINTS_HEADER {
        return Err(Error::input(
            file,
            "line 1",
            format!("the header is `{header}`, expected `{POINTS_HEADER}`"),
        ));
    }
    let mut receivers = Vec::new();
    for (index, line) in lines {
        let place = format!("line {}", index + 1);
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != 6 {
            return Err(Error::input(
                file,
                place,
                format!("expected 6 columns ({POINTS_HEADER}), found {}", fields.len()),
            ));
        }
        let mut v = [0.0; 6];
        for (k, (field, name)) in fields.iter().zip(POINTS_HEADER.split(',')).enumerate() {
            v[k] = field
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    Error::input(
                        file,
                        &place,
                        format!("column `{name}` is `{field}`, not a finite number"),
                    )
                })?;
        }
        let normal = DVec3::new(v[3], v[4], v[5]);
        if normal.length() < 1e-12 {
            return Err(Error::input(file, place, "the normal (nx, ny, nz) is zero"));
        }
        receivers.push(Receiver {
            point: DVec3::new(v[0], v[1], v[2]),
            normal: normal.normalize(),
        });
    }
    if receivers.is_empty() {
        return Err(Error::input(
            file,
            "",
            "the points file has a header but no points",
        ));
    }
    Ok(receivers)
}

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
    let text = std::fs::read_to_string(points).map_err(|e| Error::unreadable(points, &e))?;
    let receivers = parse_points(&text, points)?;
    let lux = lux_at(&scene, &receivers, direct_only, mode)?;
    print!("{}", format_csv(&receivers, &lux));
    Ok(())
}
