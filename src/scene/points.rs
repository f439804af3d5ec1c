//! Points files: receivers for `haiko probe` as CSV `x,y,z,nx,ny,nz` (metres, world frame).

use std::path::Path;

use glam::DVec3;

use crate::error::{Error, Result};
use crate::scene::Receiver;

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
