//! `haiko pick ROOM --pixel X,Y`: what a pixel of the `render` image shows — patch, surface,
//! world point and normal, and the illuminance there (the value `haiko probe` gives for that
//! point and normal) — and, with `--aim LIGHT`, the unit aim vector that points that light at
//! it. Same camera and image size as `haiko render`.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use glam::DVec3;
use serde::Serialize;

use crate::cli::{load_room, open_session};
use crate::error::{Error, Result, check_finite, printable};
use crate::render::{DisplayMode, aim_direction};
use crate::scene::{DirectMode, Receiver};
use crate::session::budget::MemoryLimit;
use crate::session::frame::check_size;
use crate::session::{FrameSpec, Session};

/// A pixel of the image: column `x` from the left, row `y` from the top (docs/METHOD.md §1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pixel {
    /// Column, 0 = leftmost.
    pub x: u32,
    /// Row, 0 = top.
    pub y: u32,
}

/// A `--pixel` value that is not `X,Y`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not a pixel `X,Y` (two whole numbers ≥ 0)")]
pub struct PixelSyntax(String);

impl FromStr for Pixel {
    type Err = PixelSyntax;

    /// Parses `X,Y` (two non-negative integers).
    fn from_str(text: &str) -> std::result::Result<Self, Self::Err> {
        let bad = || PixelSyntax(text.to_string());
        let (x, y) = text.split_once(',').ok_or_else(bad)?;
        let x = x.trim().parse().map_err(|_| bad())?;
        let y = y.trim().parse().map_err(|_| bad())?;
        Ok(Pixel { x, y })
    }
}

impl fmt::Display for Pixel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{}", self.x, self.y)
    }
}

/// What a pixel shows.
#[derive(Debug, Clone, PartialEq)]
pub struct PickReport {
    /// Fine patch id (index into the scene's fine mesh).
    pub patch: u32,
    /// Name of the patch's surface (`floor`, `wall-y1`, `box0-top`, …).
    pub surface: String,
    /// World point seen at the pixel centre (m).
    pub point: DVec3,
    /// Unit normal of the patch (world), pointing into the room.
    pub normal: DVec3,
    /// With `--aim LIGHT`: the unit vector from the light's position to `point` (world).
    pub aim: Option<DVec3>,
    /// New illuminance at `point` on the surface facing `normal`, lx: exact direct light plus
    /// (unless direct only) the gathered indirect light, as `haiko probe` computes it.
    pub lux: f64,
}

/// Picks pixel `pixel` of the `width × height` image of the session's camera, with the
/// illuminance at the picked point (direct light only with `direct_only`); with `aim_light`,
/// also the aim vector of that light towards the picked point.
///
/// Errors (bad input): a bad image size, a pixel outside the image, an unknown light (the
/// message lists the lights), a background pixel, or a light sitting on the picked point.
pub fn pick_pixel(
    session: &mut Session,
    width: u32,
    height: u32,
    pixel: Pixel,
    aim_light: Option<&str>,
    direct_only: bool,
) -> Result<PickReport> {
    check_pixel(pixel, width, height)?;
    let light = aim_light
        .map(|name| session.light_named(name, "--aim"))
        .transpose()?;
    session.render(&FrameSpec::new((width, height), DisplayMode::Photo))?;
    let hit = session
        .pick((pixel.x, pixel.y))
        .ok_or_else(|| Error::input("--pixel", "", format!("nothing at pixel {pixel} (background)")))?;
    let surface = session
        .scene()
        .surfaces
        .get(hit.surface as usize)
        .ok_or_else(|| {
            Error::internal(format!(
                "pick: patch {} has no surface {}",
                hit.patch, hit.surface
            ))
        })?;
    let aim = match light {
        Some(i) => {
            let light = &session.lights()[i];
            Some(aim_direction(light.position, hit.point).ok_or_else(|| {
                Error::input(
                    "--aim",
                    "",
                    format!(
                        "light `{}` sits on the picked point; it cannot aim at it",
                        light.name
                    ),
                )
            })?)
        }
        None => None,
    };
    let surface = surface.name.clone();
    let receiver = Receiver {
        point: hit.point,
        normal: hit.normal,
    };
    let lux = session.illuminance_at(&[receiver], direct_only, DirectMode::Exact)?[0];
    Ok(PickReport {
        patch: hit.patch,
        surface,
        point: hit.point,
        normal: hit.normal,
        aim,
        lux,
    })
}

/// Refuses a bad image size or a pixel outside the image (bad input naming the flag).
pub(crate) fn check_pixel(pixel: Pixel, width: u32, height: u32) -> Result<()> {
    check_size(width, height, ["--width", "--height"])?;
    if pixel.x >= width || pixel.y >= height {
        return Err(Error::input(
            "--pixel",
            "",
            format!("pixel {pixel} is outside the {width}×{height} image (x < {width}, y < {height})"),
        ));
    }
    Ok(())
}

#[derive(Serialize)]
struct PickJson<'a> {
    patch: u32,
    surface: &'a str,
    point: [f64; 3],
    normal: [f64; 3],
    lux: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    aim: Option<[f64; 3]>,
}

/// The report as one line of JSON: `{"patch": n, "surface": "floor", "point": [x, y, z],
/// "normal": [x, y, z], "lux": e, "aim": [x, y, z]}` (`aim` only when asked for).
pub fn to_json(report: &PickReport) -> Result<String> {
    let doc = PickJson {
        patch: report.patch,
        surface: &report.surface,
        point: report.point.to_array(),
        normal: report.normal.to_array(),
        lux: report.lux,
        aim: report.aim.map(|a| a.to_array()),
    };
    let mut out = Vec::new();
    doc.serialize(&mut serde_json::Serializer::with_formatter(
        &mut out,
        SpacedFormatter,
    ))
    .map_err(|e| Error::internal(format!("pick: JSON: {e}")))?;
    String::from_utf8(out).map_err(|e| Error::internal(format!("pick: JSON: {e}")))
}

/// Compact JSON with a space after every `:` and `,`.
struct SpacedFormatter;

impl serde_json::ser::Formatter for SpacedFormatter {
    fn begin_array_value<W: ?Sized + std::io::Write>(
        &mut self,
        w: &mut W,
        first: bool,
    ) -> std::io::Result<()> {
        if first { Ok(()) } else { w.write_all(b", ") }
    }
    fn begin_object_key<W: ?Sized + std::io::Write>(
        &mut self,
        w: &mut W,
        first: bool,
    ) -> std::io::Result<()> {
        if first { Ok(()) } else { w.write_all(b", ") }
    }
    fn begin_object_value<W: ?Sized + std::io::Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        w.write_all(b": ")
    }
}

/// The report as text, one item per line.
pub(crate) fn to_text(report: &PickReport, aim_light: Option<&str>) -> String {
    let v = |d: DVec3| format!("[{:.4}, {:.4}, {:.4}]", d.x, d.y, d.z);
    let mut text = format!(
        "patch   {} (surface {})\npoint   {} m\nnormal  {}\nE       {:.1} lx\n",
        report.patch,
        printable(&report.surface),
        v(report.point),
        v(report.normal),
        report.lux
    );
    if let (Some(aim), Some(name)) = (report.aim, aim_light) {
        text.push_str(&format!("aim     {} (light {})\n", v(aim), printable(name)));
    }
    text
}

/// Runs the command: prints the report as text or, with `json`, as one JSON line. The session
/// bakes (or reads the user's bake cache) for the indirect light unless `direct_only`.
pub fn run(
    room: &Path,
    pixel: Pixel,
    (width, height): (u32, u32),
    json: bool,
    aim_light: Option<&str>,
    direct_only: bool,
    limit: &MemoryLimit,
) -> Result<()> {
    let scene = load_room(room)?;
    check_pixel(pixel, width, height)?;
    let mut session = open_session(scene, !direct_only, limit)?;
    let report = pick_pixel(&mut session, width, height, pixel, aim_light, direct_only)?;
    let vectors = [Some(report.point), Some(report.normal), report.aim];
    check_finite(
        "pick: a coordinate",
        vectors
            .iter()
            .flatten()
            .flat_map(|v| v.to_array())
            .chain([report.lux]),
    )?;
    if json {
        println!("{}", to_json(&report)?);
    } else {
        print!("{}", to_text(&report, aim_light));
    }
    Ok(())
}
