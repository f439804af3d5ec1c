//! Receiver points from a CSV file (`haiko probe --points`): a header `x,y,z,nx,ny,nz`, then one
//! point per row, metres in the world frame (z up), with the normal of the side that receives
//! light (normalised on reading). Blank lines are skipped.
//!
//! Limits (docs/DECISIONS.md, "Bad input"): at most [`MAX_POINTS`] rows, numbers within
//! ±[`MAX_COORDINATE_M`], points inside the room or on its walls (within 10⁻⁶ of its size),
//! normals not zero. A file whose first line is not the header is not
//! quoted in the error; after the header, at most the offending field is.

use std::path::Path;

use glam::DVec3;

use crate::error::{Error, Result, quoted};
use crate::fsio::{self, FileKind};
use crate::scene::Receiver;

/// The header the points file must start with.
pub(crate) const POINTS_HEADER: &str = "x,y,z,nx,ny,nz";

/// The most points a file may hold.
pub const MAX_POINTS: usize = 1_000_000;

/// The largest coordinate magnitude of a point, metres.
pub(crate) const MAX_COORDINATE_M: f64 = 1e6;

/// Reads a points file through [`crate::fsio`] and parses it with [`parse_points`].
pub(crate) fn read_points(path: &Path, room_size: DVec3) -> Result<Vec<Receiver>> {
    let text = fsio::read_text(path, FileKind::Points)?;
    parse_points(&text, path, room_size)
}

/// Parses points CSV text for a room spanning `(0, 0, 0)` to `room_size` (m); `file` names it in
/// errors. A point outside the room is refused: it would be lit through the walls.
pub fn parse_points(text: &str, file: &Path, room_size: DVec3) -> Result<Vec<Receiver>> {
    let slack = DVec3::splat(1e-6 * (1.0 + room_size.max_element()));
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((header_index, header)) = lines.next() else {
        return Err(Error::input(
            file,
            "",
            format!("the points file is empty (expected the header `{POINTS_HEADER}`)"),
        ));
    };
    let header: Vec<&str> = header
        .trim_start_matches('\u{feff}')
        .split(',')
        .map(str::trim)
        .collect();
    if header.join(",") != POINTS_HEADER {
        return Err(Error::input(
            file,
            format!("line {}", header_index + 1),
            format!("the first line must be the header `{POINTS_HEADER}`"),
        ));
    }
    let mut points = Vec::new();
    for (index, line) in lines {
        let place = format!("line {}", index + 1);
        if points.len() == MAX_POINTS {
            return Err(Error::input(
                file,
                place,
                format!("more than {MAX_POINTS} points; split the file"),
            ));
        }
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
                .filter(|x| x.abs() <= MAX_COORDINATE_M)
                .ok_or_else(|| {
                    Error::input(
                        file,
                        &place,
                        format!(
                            "column `{name}` is {}, not a number from −{MAX_COORDINATE_M:e} to {MAX_COORDINATE_M:e}",
                            quoted(field)
                        ),
                    )
                })?;
        }
        let point = DVec3::new(v[0], v[1], v[2]);
        if !(point.cmpge(-slack).all() && point.cmple(room_size + slack).all()) {
            return Err(Error::input(
                file,
                place,
                format!(
                    "the point {:?} is outside the room, which spans [0.0, 0.0, 0.0] to {:?} m",
                    point.to_array(),
                    room_size.to_array()
                ),
            ));
        }
        let normal = DVec3::new(v[3], v[4], v[5]);
        let largest = normal.abs().max_element();
        if largest == 0.0 {
            return Err(Error::input(file, place, "the normal (nx, ny, nz) is zero"));
        }
        points.push(Receiver {
            point,
            normal: (normal / largest).normalize(),
        });
    }
    if points.is_empty() {
        return Err(Error::input(
            file,
            "",
            "the points file has a header but no points",
        ));
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROOM: DVec3 = DVec3::new(4.0, 3.0, 3.0);

    fn error(text: &str) -> String {
        parse_points(text, Path::new("p.csv"), ROOM)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn rows_become_points_with_unit_normals() {
        let p = parse_points(
            "\u{feff}x, y, z, nx, ny, nz\n\n1,2,3,0,0,2\n0,0,0,1e-300,0,0\n",
            Path::new("p.csv"),
            ROOM,
        )
        .unwrap();
        assert_eq!(p[0].point, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(p[0].normal, DVec3::Z);
        assert_eq!(p[1].normal, DVec3::X, "tiny normals scale before normalising");
    }

    #[test]
    fn a_foreign_file_is_not_quoted_and_bad_fields_are_short() {
        let e = error("root:x:0:0:root:/root:/bin/bash\n");
        assert_eq!(
            e,
            "p.csv: line 1: the first line must be the header `x,y,z,nx,ny,nz`"
        );
        let e = error("x,y,z,nx,ny,nz\n1,2,1e7,0,0,1\n");
        assert!(
            e.contains("line 2") && e.contains("`1e7`") && e.contains("column `z`"),
            "{e}"
        );
        let e = error("x,y,z,nx,ny,nz\n1,2,\u{1b}[2Jabcdefghijklmnopqrstuvwxyz,0,0,1\n");
        assert!(e.contains("`\\u{1b}[2Jabcdefghijklmnopqrst…`"), "{e}");
    }

    #[test]
    fn points_outside_the_room_are_refused_and_its_walls_kept() {
        // The walls' planes and the corner (4, 3, 3) itself, and a hair past it (rounding).
        let p = parse_points(
            "x,y,z,nx,ny,nz\n0,1,1,1,0,0\n4,3,3,0,0,-1\n4.000001,3,3,-1,0,0\n",
            Path::new("p.csv"),
            ROOM,
        )
        .unwrap();
        assert_eq!(p.len(), 3);
        for (row, line) in [
            ("-500,-500,-500", 2),
            ("10,1,0", 2),
            ("1,1,3.01", 2),
            ("2,-0.001,1", 2),
        ] {
            let e = error(&format!("x,y,z,nx,ny,nz\n{row},0,0,1\n"));
            assert!(
                e.starts_with(&format!("p.csv: line {line}: the point ["))
                    && e.ends_with("is outside the room, which spans [0.0, 0.0, 0.0] to [4.0, 3.0, 3.0] m"),
                "{e}"
            );
        }
    }
}
