//! Loading a room file: read (through [`crate::fsio`]) → parse (serde,
//! [`crate::scene::room_file`]) → validate ([`check`]: shapes, ranges, the files it names) →
//! mesh ([`CheckedRoom::mesh`]).
//!
//! Every rejection is an [`Error::input`] naming the room file and `line L, column C (field)`.
//! Every number has a range (the constants below, docs/ROOM_FILE.md "Limits") chosen so that no
//! product or sum downstream can overflow or become NaN.

use glam::DVec3;
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

use crate::error::{Error, Result, printable, quoted};
use crate::fsio::{self, FileKind};
use crate::photometry::lidfile::MAX_ANGLES;
use crate::photometry::{Curve, LuminousShape, read_lid_file};
use crate::scene::design::Design;
use crate::scene::enclosure::Neighbourhood;
use crate::scene::mesher::{self, Geometry, Shape, TriangleSurface};
use crate::scene::model::{
    Aabb, AimSpec, Camera, DirectMode, EngineChoice, LidSource, Light, Reflectance, Scene, Settings, Surface,
    SurfaceKind,
};
use crate::scene::obj::{self, Placement};
use crate::scene::room_file::{
    self, BoxSpec, CameraSpec, DirectSpec, IndirectSpec, LightSpec, MeshSpec, ReflectanceSpec, RoomFile,
    SettingsSpec, Vec3Spec,
};

mod design;

/// The most fine (or coarse) vertices a room may have; more is refused with advice to raise
/// the patch size (or to simplify the OBJ meshes when they alone exceed it).
pub(crate) const MAX_VERTICES: usize = 2_000_000;

/// Reflectances at or above this are refused: the interreflection becomes singular near 1.
pub(crate) const MAX_REFLECTANCE: f64 = 0.98;

/// The highest spherical-harmonic order a light may fix.
pub const MAX_ORDER: i64 = 150;

/// Default vertical field of view of the camera, degrees.
pub(crate) const DEFAULT_FOV_DEG: f64 = 60.0;

/// The smallest room dimension, metres: below it the fixed lengths of the light transport (the
/// 1 µm a receiver keeps from a light, the 0.15 m mounting distance, ray offsets) are no longer
/// small against the room.
pub(crate) const MIN_ROOM_SIZE_M: f64 = 0.1;

/// The largest room dimension, metres.
pub(crate) const MAX_ROOM_SIZE_M: f64 = 1000.0;

/// The largest coordinate magnitude (m) of points that may lie outside the room: aim targets,
/// the camera, an OBJ's translation.
pub(crate) const MAX_COORDINATE_M: f64 = 1e6;

/// The smallest `patch_size` / `solver_patch_size`, metres (the largest is the largest room
/// dimension, [`MAX_ROOM_SIZE_M`]).
pub(crate) const MIN_PATCH_SIZE_M: f64 = 0.001;

/// The smallest spacing of a calculation grid (`[[surface]] spacing`), metres.
pub(crate) const MIN_GRID_SPACING_M: f64 = 0.001;

/// The largest dimmer factor (the curve's intensities times this stay within 1e11 cd).
pub(crate) const MAX_DIMMER: f64 = 100.0;

/// The largest colour multiplier of a channel.
pub(crate) const MAX_COLOR: f64 = 100.0;

/// The largest luminous radius of a light, metres.
pub(crate) const MAX_RADIUS_M: f64 = 10.0;

/// The field of view range of the camera, degrees.
pub(crate) const FOV_RANGE_DEG: (f64, f64) = (1.0, 170.0);

/// The smallest solver tolerance (f64 round-off is about 1e-16; the solve cannot certify less).
pub(crate) const MIN_TOLERANCE: f64 = 1e-9;

/// The uniform scale range of an OBJ.
pub(crate) const SCALE_RANGE: (f64, f64) = (1e-6, 1e6);

/// The most lights, boxes and meshes a room may have.
pub(crate) const MAX_LIGHTS: usize = 10_000;
/// See [`MAX_LIGHTS`].
pub(crate) const MAX_BOXES: usize = 1_000;
/// See [`MAX_LIGHTS`].
pub(crate) const MAX_MESHES: usize = 100;

/// The longest message of the TOML parser quoted in an error (characters).
const MAX_PARSER_MESSAGE_CHARS: usize = 200;

/// A room file's text as read, and its content hash (FNV-1a 64) for noticing a change on disk
/// before saving ([`crate::scene::save`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RoomText {
    /// The file's text (UTF-8).
    pub text: String,
    /// [`crate::fsio::content_hash`] of the text's bytes.
    pub hash: u64,
}

impl RoomText {
    /// Wraps `text` with its hash.
    pub fn new(text: String) -> Self {
        let hash = fsio::content_hash(text.as_bytes());
        RoomText { text, hash }
    }
}

/// Reads the room file at `path` through [`crate::fsio`] (a regular UTF-8 file of at most
/// 16 MiB).
pub fn read_room(path: &Path) -> Result<RoomText> {
    fsio::read_text(path, FileKind::Room).map(RoomText::new)
}

/// Loads and meshes the room file at `path` (docs/ROOM_FILE.md).
///
/// Relative `file` / `lid_file` paths are resolved against the room file's directory. Without a
/// `[camera]`, the eye stands near the (0, 0) corner at 1.6 m (80 % of the height in rooms
/// lower than 2 m) and looks at the centre of the room.
pub fn load(path: &Path) -> Result<Scene> {
    load_text(path, &read_room(path)?.text)
}

/// Loads and meshes a room from its text, as read from `path` (which names it in errors and
/// anchors relative paths).
pub(crate) fn load_text(path: &Path, text: &str) -> Result<Scene> {
    check(path, text)?.mesh(MAX_VERTICES)
}

/// A room loaded from `text` for a unit test (no file: it may not name OBJ or photometric files).
#[cfg(test)]
pub(crate) fn test_room(text: &str) -> Scene {
    load_text(Path::new("test-room.toml"), text).expect("the test room is valid")
}

/// Parses and validates a room file's text, reading the OBJ and photometric files it names,
/// without meshing: every rejection of [`load`] except the vertex limit.
pub fn check(path: &Path, text: &str) -> Result<CheckedRoom> {
    let file: RoomFile = toml::from_str(text).map_err(|e| {
        let place = e
            .span()
            .map(|s| room_file::line_column(text, s.start))
            .unwrap_or_default();
        let message = e.message().trim_end();
        let mut shown: String = message.chars().take(MAX_PARSER_MESSAGE_CHARS).collect();
        if shown.len() < message.len() {
            shown.push('…');
        }
        Error::input(path, place, shown)
    })?;
    Loader { path, text }.check(file)
}

/// A validated room, not yet meshed (from [`check`]).
#[derive(Debug, Clone)]
pub struct CheckedRoom {
    path: PathBuf,
    name: String,
    room_size: DVec3,
    room_reflectances: RoomReflectances,
    boxes: Vec<Aabb>,
    box_reflectances: Vec<Reflectance>,
    obj_surfaces: Vec<obj::ObjSurface>,
    mesh_bounds: Vec<Aabb>,
    lights: Vec<Light>,
    camera: Camera,
    settings: Settings,
    design: Design,
    /// What loading repaired, one sentence each ([`Scene::notes`]).
    notes: Vec<String>,
    /// Where `patch_size` and `solver_patch_size` are (or would be) in the file, for errors.
    size_places: [String; 2],
}

impl CheckedRoom {
    /// The lights, as loaded.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// The number of OBJ triangles (before subdivision).
    pub(crate) fn obj_triangles(&self) -> usize {
        self.obj_surfaces.iter().map(|s| s.geometry.triangles.len()).sum()
    }

    /// Meshes the room into fine and coarse patches, refusing a mesh above `max_vertices`
    /// vertices (the room's limit is [`MAX_VERTICES`]).
    pub fn mesh(self, max_vertices: usize) -> Result<Scene> {
        // Each OBJ triangle may need its own three vertices at any patch size.
        let obj_vertices = 3 * self.obj_triangles();
        if obj_vertices > max_vertices {
            return Err(Error::input(
                &self.path,
                "[[mesh]]",
                format!(
                    "the OBJ meshes have {} triangles, which may need {obj_vertices} vertices at any \
                     patch size (the limit is {max_vertices}): simplify the OBJ files",
                    self.obj_triangles()
                ),
            ));
        }
        let (meshes, obj_reflectances): (Vec<TriangleSurface>, Vec<Reflectance>) = self
            .obj_surfaces
            .into_iter()
            .map(|s| (s.geometry, s.reflectance))
            .unzip();
        let geometry = Geometry {
            room_size: self.room_size,
            boxes: &self.boxes,
            meshes: &meshes,
        };
        let layout = mesher::layout(&geometry);
        let room = &self.room_reflectances;
        let surfaces = layout
            .iter()
            .map(|s| Surface {
                name: s.name.clone(),
                kind: s.kind.clone(),
                reflectance: match (&s.kind, s.shape) {
                    (_, Shape::Triangles(k)) => obj_reflectances[k],
                    (SurfaceKind::Floor, _) => room.floor,
                    (SurfaceKind::Ceiling, _) => room.ceiling,
                    (SurfaceKind::BoxFace { box_index }, _) => self.box_reflectances[*box_index],
                    _ => room.walls,
                },
            })
            .collect();
        let mesh_at = |size: f64, field: &str, place: &str| {
            mesher::mesh(&geometry, &layout, size, max_vertices).map_err(|too_many| {
                let message = format!(
                    "{field} = {size} m would make about {:.0} vertices (the limit is {max_vertices}); \
                     use a larger {field}",
                    too_many.estimated
                );
                Error::input(&self.path, place, message)
            })
        };
        let fine = mesh_at(self.settings.patch_size, "patch_size", &self.size_places[0])?;
        let coarse = mesh_at(
            self.settings.solver_patch_size,
            "solver_patch_size",
            &self.size_places[1],
        )?;
        Ok(Scene {
            path: self.path,
            name: self.name,
            room_size: self.room_size,
            surfaces,
            fine,
            coarse,
            boxes: self.boxes,
            mesh_bounds: self.mesh_bounds,
            lights: self.lights,
            camera: self.camera,
            settings: self.settings,
            design: self.design,
            notes: self.notes,
        })
    }
}

/// Reflectances of the room's own surfaces.
#[derive(Debug, Clone)]
struct RoomReflectances {
    floor: Reflectance,
    walls: Reflectance,
    ceiling: Reflectance,
}

/// The room file being loaded, for error places.
struct Loader<'a> {
    path: &'a Path,
    text: &'a str,
}

/// A number's allowed range: `lo` (excluded when `lo_open`) to `hi` (included).
#[derive(Debug, Clone, Copy)]
struct Bounds {
    lo: f64,
    lo_open: bool,
    hi: f64,
}

impl Bounds {
    /// `lo ≤ x ≤ hi`.
    const fn closed(lo: f64, hi: f64) -> Self {
        Bounds {
            lo,
            lo_open: false,
            hi,
        }
    }
    /// `lo < x ≤ hi`.
    const fn above(lo: f64, hi: f64) -> Self {
        Bounds {
            lo,
            lo_open: true,
            hi,
        }
    }
    fn contains(self, x: f64) -> bool {
        (if self.lo_open { x > self.lo } else { x >= self.lo }) && x <= self.hi
    }
    fn describe(self) -> String {
        let relation = if self.lo_open { ">" } else { "≥" };
        format!("a number {relation} {} and ≤ {}", shown(self.lo), shown(self.hi))
    }
}

impl Loader<'_> {
    /// An input error at `span`, naming `field`.
    fn error(&self, span: &Range<usize>, field: &str, message: impl Into<String>) -> Error {
        Error::input(self.path, room_file::place(self.text, span, field), message)
    }

    /// A path from the file, resolved against the room file's directory.
    fn resolve(&self, written: &str) -> PathBuf {
        self.path.parent().unwrap_or(Path::new("")).join(written)
    }

    /// Where an optional setting is in the file (or where its default applies).
    fn setting_place(&self, spec: &Option<Spanned<f64>>, field: &str) -> String {
        match spec {
            Some(s) => room_file::place(self.text, &s.span(), &format!("settings.{field}")),
            None => format!("settings.{field} (default)"),
        }
    }

    fn check(&self, file: RoomFile) -> Result<CheckedRoom> {
        if *file.version.get_ref() != 1 {
            let message = format!(
                "room-file version {} is not supported (this Haiko reads version 1)",
                file.version.get_ref()
            );
            return Err(self.error(&file.version.span(), "version", message));
        }
        let size_range = Bounds::closed(MIN_ROOM_SIZE_M, MAX_ROOM_SIZE_M);
        let room_size = self.vector(&file.room.size, "room.size")?;
        if !room_size.to_array().into_iter().all(|x| size_range.contains(x)) {
            let message = format!(
                "every room dimension must be from {MIN_ROOM_SIZE_M} m to {MAX_ROOM_SIZE_M} m, not {:?}",
                room_size.to_array()
            );
            return Err(self.error(&file.room.size.span(), "room.size", message));
        }
        for (what, count, limit, field) in [
            ("boxes", file.boxes.len(), MAX_BOXES, "box"),
            ("meshes", file.meshes.len(), MAX_MESHES, "mesh"),
            ("lights", file.lights.len(), MAX_LIGHTS, "light"),
        ] {
            if count > limit {
                return Err(Error::input(
                    self.path,
                    format!("[[{field}]]"),
                    format!("{count} {what}: a room may have at most {limit}"),
                ));
            }
        }
        let room = &file.room.reflectance;
        let room_reflectances = RoomReflectances {
            floor: self.reflectance(&room.floor, "room.reflectance.floor")?,
            walls: self.reflectance(&room.walls, "room.reflectance.walls")?,
            ceiling: self.reflectance(&room.ceiling, "room.reflectance.ceiling")?,
        };
        let (boxes, box_reflectances) = self.boxes(&file.boxes, room_size)?;
        let mut obj_surfaces = Vec::new();
        let mut mesh_bounds = Vec::with_capacity(file.meshes.len());
        let mut notes = Vec::new();
        for (i, spec) in file.meshes.iter().enumerate() {
            let (surfaces, bounds, mesh_notes) = self.obj(spec.get_ref(), i, room_size)?;
            obj_surfaces.extend(surfaces);
            mesh_bounds.push(bounds);
            notes.extend(mesh_notes);
        }
        if let Some((earlier, later, corners)) = obj::first_repeated_triangle(&obj_surfaces) {
            let copy = if earlier == later {
                "twice in that mesh".to_string()
            } else {
                format!("in mesh[{earlier}] too")
            };
            let message = format!(
                "the triangle {:?} appears {copy}, facing the same way: coincident faces reflect \
                 each other's light without end; remove the copy",
                corners.map(|c| c.to_array())
            );
            return Err(self.error(&file.meshes[later].span(), &format!("mesh[{later}]"), message));
        }
        let solids = Solids {
            room_size,
            boxes: &boxes,
            mesh_bounds: &mesh_bounds,
            obj_surfaces: &obj_surfaces,
        };
        let lights = self.lights(&file.lights, &solids)?;
        let settings = self.settings(&file.settings)?;
        let bounds = design::RoomBounds {
            size: room_size,
            boxes: &boxes,
            mesh_bounds: &mesh_bounds,
        };
        let design = self.design(
            &file.surfaces,
            &file.observers,
            &file.settings.maintenance_factor,
            &bounds,
        )?;
        let camera = match &file.camera {
            Some(spec) => self.camera(spec)?,
            None => default_camera(room_size),
        };
        let stem = self.path.file_stem().map(|s| s.to_string_lossy().into_owned());
        Ok(CheckedRoom {
            path: self.path.to_path_buf(),
            name: file.name.or(stem).unwrap_or_default(),
            room_size,
            room_reflectances,
            boxes,
            box_reflectances,
            obj_surfaces,
            mesh_bounds,
            lights,
            camera,
            settings,
            notes,
            size_places: [
                self.setting_place(&file.settings.patch_size, "patch_size"),
                self.setting_place(&file.settings.solver_patch_size, "solver_patch_size"),
            ],
            design,
        })
    }

    /// The boxes and their reflectances.
    fn boxes(&self, specs: &[Spanned<BoxSpec>], room_size: DVec3) -> Result<(Vec<Aabb>, Vec<Reflectance>)> {
        let mut boxes = Vec::with_capacity(specs.len());
        let mut reflectances = Vec::with_capacity(specs.len());
        for (i, spec) in specs.iter().enumerate() {
            let spec = spec.get_ref();
            let field = format!("box[{i}]");
            let min = self.vector(&spec.min, &format!("{field}.min"))?;
            let max = self.vector(&spec.max, &format!("{field}.max"))?;
            if !min.cmplt(max).all() {
                let message = "max must exceed min on every axis";
                return Err(self.error(&spec.max.span(), &format!("{field}.max"), message));
            }
            if min.min_element() < 0.0 || !max.cmple(room_size).all() {
                return Err(self.error(&spec.min.span(), &field, "the box must lie inside the room"));
            }
            boxes.push(Aabb { min, max });
            reflectances.push(self.reflectance(&spec.reflectance, &format!("{field}.reflectance"))?);
        }
        Ok((boxes, reflectances))
    }

    /// The lights, with unique names.
    fn lights(&self, specs: &[Spanned<LightSpec>], solids: &Solids) -> Result<Vec<Light>> {
        let mut lights: Vec<Light> = Vec::with_capacity(specs.len());
        let mut by_name: HashMap<String, usize> = HashMap::with_capacity(specs.len());
        for (i, spec) in specs.iter().enumerate() {
            let light = self.light(spec, i, solids)?;
            if let Some(j) = by_name.insert(light.name.clone(), i) {
                let message = format!("the name {} is already used by light[{j}]", quoted(&light.name));
                return Err(self.error(&spec.get_ref().name.span(), &format!("light[{i}].name"), message));
            }
            lights.push(light);
        }
        Ok(lights)
    }

    /// Exactly three finite numbers.
    fn vector(&self, spec: &Spanned<Vec3Spec>, field: &str) -> Result<DVec3> {
        let v = spec.get_ref();
        if v.len() != 3 {
            let message = format!("needs exactly 3 numbers [x, y, z], not {}", v.len());
            return Err(self.error(&spec.span(), field, message));
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(self.error(&spec.span(), field, format!("{v:?} must be finite numbers")));
        }
        Ok(DVec3::new(v[0], v[1], v[2]))
    }

    /// A point that may lie outside the room: three numbers within ±[`MAX_COORDINATE_M`].
    fn point(&self, spec: &Spanned<Vec3Spec>, field: &str) -> Result<DVec3> {
        let p = self.vector(spec, field)?;
        if p.abs().max_element() > MAX_COORDINATE_M {
            let message = format!(
                "{:?}: every coordinate must be within ±{MAX_COORDINATE_M:e} m",
                p.to_array()
            );
            return Err(self.error(&spec.span(), field, message));
        }
        Ok(p)
    }

    /// A number in `range`.
    fn number(&self, spec: &Spanned<f64>, field: &str, range: Bounds) -> Result<f64> {
        let x = *spec.get_ref();
        if !range.contains(x) {
            return Err(self.error(
                &spec.span(),
                field,
                format!("{} must be {}", shown(x), range.describe()),
            ));
        }
        Ok(x)
    }

    fn reflectance(&self, spec: &Spanned<ReflectanceSpec>, field: &str) -> Result<Reflectance> {
        let channels = match spec.get_ref() {
            ReflectanceSpec::Grey(rho) => [*rho; 3],
            ReflectanceSpec::Rgb(rgb) => match rgb.as_slice() {
                &[r, g, b] => [r, g, b],
                _ => {
                    let message = format!(
                        "needs one number or exactly 3 numbers [r, g, b], not {}",
                        rgb.len()
                    );
                    return Err(self.error(&spec.span(), field, message));
                }
            },
        };
        for rho in channels {
            if !(0.0..MAX_REFLECTANCE).contains(&rho) {
                return Err(self.error(
                    &spec.span(),
                    field,
                    format!(
                        "reflectance {rho} must be ≥ 0 and below {MAX_REFLECTANCE} (the interreflection \
                         becomes singular as reflectance approaches 1)"
                    ),
                ));
            }
        }
        Ok(Reflectance(channels))
    }

    /// An error from a file the room names (OBJ, photometric file), located at the room file's
    /// `field` and naming the file as written; the inner file is repeated only when it is
    /// another one (an MTL of an OBJ).
    fn nested(
        &self,
        span: &Range<usize>,
        field: &str,
        what: &str,
        written: &str,
        resolved: &Path,
        e: Error,
    ) -> Error {
        match e {
            Error::Input(inner) => {
                let location = match (
                    inner.file == resolved.display().to_string(),
                    inner.place.is_empty(),
                ) {
                    // A file-level error (missing, unreadable): say where the path led.
                    (true, true) if Path::new(written) != resolved => {
                        format!("(resolved to {}): ", quoted_path(&resolved.display().to_string()))
                    }
                    (true, true) => String::new(),
                    (true, false) => format!("{}: ", inner.place),
                    (false, true) => format!("{}: ", inner.file),
                    (false, false) => format!("{}: {}: ", inner.file, inner.place),
                };
                let written = quoted_path(written);
                let message = match location.strip_prefix('(') {
                    Some(_) => format!("{what} {written} {location}{}", inner.message),
                    None => format!("{what} {written}: {location}{}", inner.message),
                };
                self.error(span, field, message)
            }
            internal @ Error::Internal(_) => internal,
        }
    }

    /// Reads, places and checks `[[mesh]]` number `index`: its surfaces, its world bounds and the
    /// import's notes (each starting with the field).
    fn obj(
        &self,
        spec: &MeshSpec,
        index: usize,
        room_size: DVec3,
    ) -> Result<(Vec<obj::ObjSurface>, Aabb, Vec<String>)> {
        let field = format!("mesh[{index}]");
        let written = spec.file.get_ref();
        let resolved = self.resolve(written);
        let span = spec.file.span();
        let file_field = format!("{field}.file");
        let file_error = |message: String| self.error(&span, &file_field, message);
        let scale = match &spec.scale {
            Some(s) => self.number(
                s,
                &format!("{field}.scale"),
                Bounds::closed(SCALE_RANGE.0, SCALE_RANGE.1),
            )?,
            None => 1.0,
        };
        let translate = match &spec.translate {
            Some(t) => self.point(t, &format!("{field}.translate"))?,
            None => DVec3::ZERO,
        };
        let placement = Placement {
            up: spec.up,
            scale,
            translate,
        };
        let obj::ObjImport { surfaces, notes } = obj::read_obj(&resolved, index, &placement)
            .map_err(|e| self.nested(&span, &file_field, "OBJ", written, &resolved, e))?;
        let mut points = surfaces
            .iter()
            .flat_map(|s| s.geometry.positions.iter().copied())
            .peekable();
        if points.peek().is_none() {
            let message = format!("OBJ {} has no faces of nonzero area", quoted_path(written));
            return Err(file_error(message));
        }
        let (min, max) = points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
        let slack = 1e-9 * (1.0 + room_size.max_element());
        if !(min.cmpge(DVec3::splat(-slack)).all() && max.cmple(room_size + slack).all()) {
            return Err(file_error(format!(
                "OBJ {} spans {:?} to {:?} m after placement, outside the room (0, 0, 0) to {:?}",
                quoted_path(written),
                min.to_array(),
                max.to_array(),
                room_size.to_array()
            )));
        }
        let notes = notes.into_iter().map(|n| format!("{field}: {n}")).collect();
        Ok((surfaces, Aabb { min, max }, notes))
    }

    fn light(&self, spec: &Spanned<LightSpec>, index: usize, solids: &Solids) -> Result<Light> {
        let field = format!("light[{index}]");
        let at = |name: &str| format!("{field}.{name}");
        let table = spec.span();
        let spec = spec.get_ref();
        let position = self.light_position(&spec.position, &at("position"), solids)?;
        let (aim, aim_spec) = self.aim(spec, position, &field)?;
        let (curve, lid_source, file_luminous) = match (&spec.lid, &spec.lid_file) {
            (Some(_), Some(file)) => {
                let message = "give either `lid` or `lid_file`, not both";
                return Err(self.error(&file.span(), &at("lid_file"), message));
            }
            (None, None) => {
                let message = "the light needs a curve: `lid = [[γ°, cd], …]` or `lid_file`";
                return Err(self.error(&table, &field, message));
            }
            (Some(points), None) => (self.inline_curve(points, &at("lid"))?, LidSource::Inline, None),
            (None, Some(file)) => self.lid_file(file, &at("lid_file"))?,
        };
        let order = match &spec.order {
            Some(o) if !(0..=MAX_ORDER).contains(o.get_ref()) => {
                let message = format!("order {} must be between 0 and {MAX_ORDER}", o.get_ref());
                return Err(self.error(&o.span(), &at("order"), message));
            }
            Some(o) => Some(*o.get_ref() as usize),
            None => None,
        };
        let optional = |value: &Option<Spanned<f64>>, name: &str, range: Bounds, default: f64| match value {
            Some(v) => self.number(v, &at(name), range),
            None => Ok(default),
        };
        let radius = optional(&spec.radius, "radius", Bounds::closed(0.0, MAX_RADIUS_M), 0.0)?;
        let dimmer = optional(&spec.dimmer, "dimmer", Bounds::closed(0.0, MAX_DIMMER), 1.0)?;
        let color = match &spec.color {
            Some(c) => {
                let rgb = self.vector(c, &at("color"))?;
                if !(rgb.cmpge(DVec3::ZERO).all() && rgb.cmple(DVec3::splat(MAX_COLOR)).all()) {
                    let message = format!("colour channels must be from 0 to {MAX_COLOR}");
                    return Err(self.error(&c.span(), &at("color"), message));
                }
                rgb.to_array()
            }
            None => [1.0; 3],
        };
        let luminous = match &spec.luminous_size {
            Some(size) => Some(self.luminous_size(size, &at("luminous_size"))?),
            None => file_luminous,
        };
        Ok(Light {
            name: spec.name.get_ref().clone(),
            position,
            aim,
            aim_spec,
            curve,
            lid_source,
            order,
            radius,
            dimmer,
            color,
            luminous,
        })
    }

    /// An inline `lid`: at most [`MAX_ANGLES`] points of exactly two numbers `[γ°, cd]`.
    fn inline_curve(&self, points: &Spanned<Vec<Spanned<Vec<f64>>>>, field: &str) -> Result<Curve> {
        if points.get_ref().len() > MAX_ANGLES {
            let message = format!(
                "{} points: a curve may have at most {MAX_ANGLES}",
                points.get_ref().len()
            );
            return Err(self.error(&points.span(), field, message));
        }
        let mut pairs = Vec::with_capacity(points.get_ref().len());
        for (k, point) in points.get_ref().iter().enumerate() {
            match point.get_ref().as_slice() {
                &[gamma_deg, cd] => pairs.push((gamma_deg, cd)),
                other => {
                    let message = format!("needs exactly 2 numbers [γ°, cd], not {}", other.len());
                    return Err(self.error(&point.span(), &format!("{field}[{k}]"), message));
                }
            }
        }
        Curve::new(&pairs).map_err(|e| self.error(&points.span(), field, e.to_string()))
    }

    /// A light position: strictly inside the room, in no box, and in no OBJ (see
    /// [`Solids::inside_mesh`]).
    fn light_position(&self, spec: &Spanned<Vec3Spec>, field: &str, solids: &Solids) -> Result<DVec3> {
        let position = self.vector(spec, field)?;
        let room_size = solids.room_size;
        let message = if !(position.cmpgt(DVec3::ZERO).all() && position.cmplt(room_size).all()) {
            format!(
                "the light at {:?} must be strictly inside the room (0, 0, 0) to {:?}",
                position.to_array(),
                room_size.to_array()
            )
        } else if let Some(b) = solids.boxes.iter().position(|b| b.contains_strictly(position)) {
            format!("the light is inside box[{b}]")
        } else if let Some(m) = solids.inside_mesh(position) {
            format!("the light is inside mesh[{m}]")
        } else if solids.encloses(position) {
            format!(
                "the light at {:?} lies between pieces of furniture that close it in on every \
                 side (a face shared by two boxes or meshes); move it onto a free face",
                position.to_array()
            )
        } else {
            return Ok(position);
        };
        Err(self.error(&spec.span(), field, message))
    }

    /// The unit aim axis from `aim` (a target) or `aim_dir`; straight down when neither is given.
    fn aim(&self, spec: &LightSpec, position: DVec3, field: &str) -> Result<(DVec3, AimSpec)> {
        match (&spec.aim, &spec.aim_dir) {
            (Some(_), Some(dir)) => {
                let message = "give either `aim` or `aim_dir`, not both";
                Err(self.error(&dir.span(), &format!("{field}.aim_dir"), message))
            }
            (Some(target), None) => {
                let point = self.point(target, &format!("{field}.aim"))?;
                let Some(axis) = unit(point - position) else {
                    let message = "the aim target is the light's own position";
                    return Err(self.error(&target.span(), &format!("{field}.aim"), message));
                };
                Ok((axis, AimSpec::Target(point)))
            }
            (None, Some(dir)) => {
                let d = self.vector(dir, &format!("{field}.aim_dir"))?;
                let Some(axis) = unit(d) else {
                    let message = "the aim direction is zero";
                    return Err(self.error(&dir.span(), &format!("{field}.aim_dir"), message));
                };
                Ok((axis, AimSpec::Direction(axis)))
            }
            (None, None) => Ok((DVec3::NEG_Z, AimSpec::Direction(DVec3::NEG_Z))),
        }
    }

    /// A curve from a photometric file, resolved against the room file's directory, and the
    /// file's luminous area.
    fn lid_file(
        &self,
        file: &Spanned<String>,
        field: &str,
    ) -> Result<(Curve, LidSource, Option<LuminousShape>)> {
        let written = file.get_ref();
        let resolved = self.resolve(written);
        let lid = read_lid_file(&resolved)
            .map_err(|e| self.nested(&file.span(), field, "photometric file", written, &resolved, e))?;
        let source = LidSource::File {
            path: resolved,
            asymmetry: lid.asymmetry,
        };
        Ok((lid.curve, source, lid.luminous))
    }

    fn settings(&self, spec: &SettingsSpec) -> Result<Settings> {
        let defaults = Settings::default();
        let setting = |value: &Option<Spanned<f64>>, name: &str, range: Bounds, default: f64| match value {
            Some(v) => self.number(v, &format!("settings.{name}"), range),
            None => Ok(default),
        };
        let patch = Bounds::closed(MIN_PATCH_SIZE_M, MAX_ROOM_SIZE_M);
        Ok(Settings {
            patch_size: setting(&spec.patch_size, "patch_size", patch, defaults.patch_size)?,
            solver_patch_size: setting(
                &spec.solver_patch_size,
                "solver_patch_size",
                patch,
                defaults.solver_patch_size,
            )?,
            direct: match spec.direct {
                Some(DirectSpec::Exact) => DirectMode::Exact,
                Some(DirectSpec::Basis) => DirectMode::Basis,
                None => defaults.direct,
            },
            tolerance: setting(
                &spec.tolerance,
                "tolerance",
                Bounds::closed(MIN_TOLERANCE, 0.5),
                defaults.tolerance,
            )?,
            indirect: match spec.indirect {
                Some(IndirectSpec::Auto) => EngineChoice::Auto,
                Some(IndirectSpec::Basis) => EngineChoice::Basis,
                Some(IndirectSpec::Hierarchical) => EngineChoice::Hierarchical,
                None => defaults.indirect,
            },
        })
    }

    fn camera(&self, spec: &Spanned<CameraSpec>) -> Result<Camera> {
        let spec = spec.get_ref();
        let eye = self.point(&spec.eye, "camera.eye")?;
        let target = self.point(&spec.target, "camera.target")?;
        if eye.distance(target) < 1e-3 {
            return Err(self.error(
                &spec.target.span(),
                "camera.target",
                "the camera target must be at least 1 mm from the eye",
            ));
        }
        let fov_deg = match &spec.fov_deg {
            Some(f) => self.number(
                f,
                "camera.fov_deg",
                Bounds::closed(FOV_RANGE_DEG.0, FOV_RANGE_DEG.1),
            )?,
            None => DEFAULT_FOV_DEG,
        };
        Ok(Camera { eye, target, fov_deg })
    }
}

/// `x` for a message: plain for ordinary magnitudes, in exponent form (`1e-9`, `1e308`) for
/// tiny and huge ones.
fn shown(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-4..1e7).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// `v` scaled to unit length (robust to tiny and huge components), or `None` when it is zero.
fn unit(v: DVec3) -> Option<DVec3> {
    let largest = v.abs().max_element();
    (largest > 0.0).then(|| (v / largest).normalize())
}

/// A path as written in the room file, quoted and escaped for a message.
fn quoted_path(written: &str) -> String {
    format!("`{}`", printable(written))
}

/// What a light may not be inside.
struct Solids<'a> {
    room_size: DVec3,
    boxes: &'a [Aabb],
    mesh_bounds: &'a [Aabb],
    obj_surfaces: &'a [obj::ObjSurface],
}

impl Solids<'_> {
    /// The first mesh that holds `p`: strictly inside its bounds, on none of its faces, and
    /// wound around by them — the generalized winding number `w = Σ Ω / 4π` over its
    /// triangles' signed solid angles is 1 inside a closed mesh and 0 outside it, whichever way
    /// its faces turn, so `|w| > ½` (docs/DECISIONS.md "A light inside an OBJ"). The bounds
    /// alone refused an up-light under a baffle hung at 30°, which lies inside the baffle's
    /// bounds but outside the baffle.
    fn inside_mesh(&self, p: DVec3) -> Option<usize> {
        let tolerance = 1e-9 * (1.0 + self.room_size.max_element());
        self.mesh_bounds.iter().enumerate().find_map(|(m, bounds)| {
            if !bounds.contains_strictly(p) {
                return None;
            }
            let triangles = || {
                self.obj_surfaces
                    .iter()
                    .filter(|s| s.geometry.mesh_index == m)
                    .flat_map(|s| {
                        let g = &s.geometry;
                        g.triangles.iter().map(|t| t.map(|i| g.positions[i as usize]))
                    })
            };
            if triangles().any(|t| on_triangle(p, t, tolerance)) {
                return None;
            }
            self.wound_by(m, p).then_some(m)
        })
    }

    /// Whether mesh `m` winds around `p` (`|w| > ½`, see [`Solids::inside_mesh`]).
    fn wound_by(&self, m: usize, p: DVec3) -> bool {
        let triangles = self
            .obj_surfaces
            .iter()
            .filter(|s| s.geometry.mesh_index == m)
            .flat_map(|s| {
                let g = &s.geometry;
                g.triangles.iter().map(|t| t.map(|i| g.positions[i as usize]))
            });
        obj::winding_number(p, triangles).abs() > 0.5
    }

    /// Whether boxes and meshes close `p` in on every side although it is inside none of them
    /// (see [`Neighbourhood::closed_in`]; a mesh holds a probe it winds around).
    fn encloses(&self, p: DVec3) -> bool {
        let around = Neighbourhood::new(p, self.room_size);
        let boxes: Vec<&Aabb> = self.boxes.iter().filter(|b| around.touches(b)).collect();
        let meshes: Vec<usize> = (0..self.mesh_bounds.len())
            .filter(|&m| around.touches(&self.mesh_bounds[m]))
            .collect();
        (!boxes.is_empty() || !meshes.is_empty())
            && around.closed_in(|q| {
                boxes.iter().any(|b| b.contains_strictly(q)) || meshes.iter().any(|&m| self.wound_by(m, q))
            })
    }
}

/// Whether `p` lies on the triangle `[a, b, c]`, within `tolerance` metres of its plane and
/// inside its edges.
fn on_triangle(p: DVec3, [a, b, c]: [DVec3; 3], tolerance: f64) -> bool {
    let normal = (b - a).cross(c - a);
    let length = normal.length();
    if length == 0.0 {
        return false;
    }
    let n = normal / length;
    if (p - a).dot(n).abs() > tolerance {
        return false;
    }
    // Inside when p is on the inner side of every edge (within the tolerance).
    [(a, b), (b, c), (c, a)]
        .iter()
        .all(|&(from, to)| (to - from).cross(p - from).dot(n) >= -tolerance * (to - from).length())
}

/// Eye near the (0, 0) corner (10 % of the room in, at most 0.5 m) at 1.6 m (80 % of the
/// height in rooms lower than 2 m), looking at the centre of the room.
fn default_camera(room_size: DVec3) -> Camera {
    let corner = (room_size * 0.1).min(DVec3::splat(0.5));
    Camera {
        eye: DVec3::new(corner.x, corner.y, (0.8 * room_size.z).min(1.6)),
        target: room_size * 0.5,
        fov_deg: DEFAULT_FOV_DEG,
    }
}
