//! Loading a room file: read → parse (serde, [`crate::scene::room_file`]) → validate → resolve
//! relative paths against the room file's directory → read OBJ and photometric files → mesh.
//!
//! Every rejection is an [`Error::input`] naming the room file and `line L, column C (field)`.

use glam::DVec3;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

use crate::error::{Error, Result};
use crate::photometry::{Curve, LuminousShape, read_lid_file};
use crate::scene::mesher::{self, Geometry, Shape, SurfaceLayout, TriangleSurface};
use crate::scene::model::{
    Aabb, AimSpec, Camera, DirectMode, LidSource, Light, PatchMesh, Reflectance, Scene, Settings, Surface,
    SurfaceKind,
};
use crate::scene::obj::{self, Placement};
use crate::scene::room_file::{
    self, BoxSpec, CameraSpec, DirectSpec, LightSpec, MeshSpec, ReflectanceSpec, RoomFile, SettingsSpec,
    Vec3Spec,
};

mod design;

/// The most fine (or coarse) vertices a room may have; more is refused with advice to raise
/// the patch size.
pub const MAX_VERTICES: usize = 2_000_000;

/// Reflectances at or above this are refused: the interreflection becomes singular near 1.
pub const MAX_REFLECTANCE: f64 = 0.98;

/// The highest spherical-harmonic order a light may fix.
pub const MAX_ORDER: i64 = 150;

/// Default vertical field of view of the camera, degrees.
pub const DEFAULT_FOV_DEG: f64 = 60.0;

/// Loads and meshes the room file at `path` (docs/ROOM_FILE.md).
///
/// Relative `file` / `lid_file` paths are resolved against the room file's directory. Without a
/// `[camera]`, the eye stands near the (0, 0) corner at 1.6 m (80 % of the height in rooms
/// lower than 2 m) and looks at the centre of the room.
pub fn load(path: &Path) -> Result<Scene> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::unreadable(path, &e))?;
    let file: RoomFile = toml::from_str(&text).map_err(|e| {
        let place = e
            .span()
            .map(|s| room_file::line_column(&text, s.start))
            .unwrap_or_default();
        Error::input(path, place, e.message().trim_end())
    })?;
    Loader { path, text: &text }.scene(file)
}

/// Reflectances of the room's own surfaces.
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

impl Loader<'_> {
    /// An input error at `span`, naming `field`.
    fn error(&self, span: &Range<usize>, field: &str, message: impl Into<String>) -> Error {
        Error::input(self.path, room_file::place(self.text, span, field), message)
    }

    /// A path from the file, resolved against the room file's directory.
    fn resolve(&self, written: &str) -> PathBuf {
        self.path.parent().unwrap_or(Path::new("")).join(written)
    }

    fn scene(&self, file: RoomFile) -> Result<Scene> {
        if *file.version.get_ref() != 1 {
            let message = format!(
                "room-file version {} is not supported (this Haiko reads version 1)",
                file.version.get_ref()
            );
            return Err(self.error(&file.version.span(), "version", message));
        }
        let room_size = self.vector(&file.room.size, "room.size")?;
        if room_size.min_element() <= 0.0 {
            let message = "every room dimension must be > 0 m";
            return Err(self.error(&file.room.size.span(), "room.size", message));
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
        for (i, spec) in file.meshes.iter().enumerate() {
            let (surfaces, bounds) = self.obj(spec.get_ref(), i, room_size)?;
            obj_surfaces.extend(surfaces);
            mesh_bounds.push(bounds);
        }
        let lights = self.lights(&file.lights, room_size, &boxes, &mesh_bounds)?;
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

        let (meshes, obj_reflectances): (Vec<TriangleSurface>, Vec<Reflectance>) = obj_surfaces
            .into_iter()
            .map(|s| (s.geometry, s.reflectance))
            .unzip();
        let geometry = Geometry {
            room_size,
            boxes: &boxes,
            meshes: &meshes,
        };
        let layout = mesher::layout(&geometry);
        let surfaces = layout
            .iter()
            .map(|s| Surface {
                name: s.name.clone(),
                kind: s.kind.clone(),
                reflectance: match (&s.kind, s.shape) {
                    (_, Shape::Triangles(k)) => obj_reflectances[k],
                    (SurfaceKind::Floor, _) => room_reflectances.floor,
                    (SurfaceKind::Ceiling, _) => room_reflectances.ceiling,
                    (SurfaceKind::BoxFace { box_index }, _) => box_reflectances[*box_index],
                    _ => room_reflectances.walls,
                },
            })
            .collect();
        let fine = self.mesh(
            &geometry,
            &layout,
            settings.patch_size,
            &file.settings.patch_size,
            "patch_size",
        )?;
        let coarse = self.mesh(
            &geometry,
            &layout,
            settings.solver_patch_size,
            &file.settings.solver_patch_size,
            "solver_patch_size",
        )?;
        let stem = self.path.file_stem().map(|s| s.to_string_lossy().into_owned());
        Ok(Scene {
            path: self.path.to_path_buf(),
            name: file.name.or(stem).unwrap_or_default(),
            room_size,
            surfaces,
            fine,
            coarse,
            boxes,
            mesh_bounds,
            lights,
            camera,
            settings,
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
    fn lights(
        &self,
        specs: &[Spanned<LightSpec>],
        room_size: DVec3,
        boxes: &[Aabb],
        mesh_bounds: &[Aabb],
    ) -> Result<Vec<Light>> {
        let mut lights: Vec<Light> = Vec::with_capacity(specs.len());
        for (i, spec) in specs.iter().enumerate() {
            let light = self.light(spec, i, room_size, boxes, mesh_bounds)?;
            if let Some(j) = lights.iter().position(|l| l.name == light.name) {
                let message = format!("the name `{}` is already used by light[{j}]", light.name);
                return Err(self.error(&spec.get_ref().name.span(), &format!("light[{i}].name"), message));
            }
            lights.push(light);
        }
        Ok(lights)
    }

    /// One patch mesh at `size` (`spec` and `field` locate the setting in errors).
    fn mesh(
        &self,
        geometry: &Geometry,
        layout: &[SurfaceLayout],
        size: f64,
        spec: &Option<Spanned<f64>>,
        field: &str,
    ) -> Result<PatchMesh> {
        mesher::mesh(geometry, layout, size, MAX_VERTICES).map_err(|too_many| {
            let message = format!(
                "{field} = {size} m would make about {:.0} vertices (the limit is {MAX_VERTICES}); \
                 use a larger {field}",
                too_many.estimated
            );
            match spec {
                Some(s) => self.error(&s.span(), &format!("settings.{field}"), message),
                None => Error::input(self.path, format!("settings.{field} (default)"), message),
            }
        })
    }

    /// A vector with every component finite.
    fn vector(&self, spec: &Spanned<Vec3Spec>, field: &str) -> Result<DVec3> {
        let v = *spec.get_ref();
        if v.iter().any(|x| !x.is_finite()) {
            return Err(self.error(&spec.span(), field, format!("{v:?} must be finite numbers")));
        }
        Ok(DVec3::from_array(v))
    }

    /// A finite number ≥ `min` (or > `min` when `strict`).
    fn number(&self, spec: &Spanned<f64>, field: &str, min: f64, strict: bool) -> Result<f64> {
        let x = *spec.get_ref();
        let ok = x.is_finite() && if strict { x > min } else { x >= min };
        if !ok {
            let relation = if strict { ">" } else { "≥" };
            return Err(self.error(
                &spec.span(),
                field,
                format!("{x} must be a finite number {relation} {min}"),
            ));
        }
        Ok(x)
    }

    fn reflectance(&self, spec: &Spanned<ReflectanceSpec>, field: &str) -> Result<Reflectance> {
        let channels = spec.get_ref().channels();
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

    /// Reads, places and checks one `[[mesh]]`; returns its surfaces and world bounds.
    fn obj(&self, spec: &MeshSpec, index: usize, room_size: DVec3) -> Result<(Vec<obj::ObjSurface>, Aabb)> {
        let field = format!("mesh[{index}]");
        let written = spec.file.get_ref();
        let resolved = self.resolve(written);
        let file_error = |message: String| self.error(&spec.file.span(), &format!("{field}.file"), message);
        if !resolved.is_file() {
            return Err(file_error(format!(
                "OBJ file `{written}` not found (resolved to `{}`)",
                resolved.display()
            )));
        }
        let scale = match &spec.scale {
            Some(s) => self.number(s, &format!("{field}.scale"), 0.0, true)?,
            None => 1.0,
        };
        let translate = match &spec.translate {
            Some(t) => self.vector(t, &format!("{field}.translate"))?,
            None => DVec3::ZERO,
        };
        let placement = Placement {
            up: spec.up,
            scale,
            translate,
        };
        let surfaces = obj::read_obj(&resolved, index, &placement)
            .map_err(|message| file_error(format!("OBJ `{written}`: {message}")))?;
        let mut points = surfaces
            .iter()
            .flat_map(|s| s.geometry.positions.iter().copied())
            .peekable();
        if points.peek().is_none() {
            return Err(file_error(format!("OBJ `{written}` has no faces")));
        }
        let (min, max) = points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
        let slack = 1e-9 * (1.0 + room_size.max_element());
        if !(min.cmpge(DVec3::splat(-slack)).all() && max.cmple(room_size + slack).all()) {
            return Err(file_error(format!(
                "OBJ `{written}` spans {:?} to {:?} m after placement, outside the room (0, 0, 0) to {:?}",
                min.to_array(),
                max.to_array(),
                room_size.to_array()
            )));
        }
        Ok((surfaces, Aabb { min, max }))
    }

    fn light(
        &self,
        spec: &Spanned<LightSpec>,
        index: usize,
        room_size: DVec3,
        boxes: &[Aabb],
        mesh_bounds: &[Aabb],
    ) -> Result<Light> {
        let field = format!("light[{index}]");
        let at = |name: &str| format!("{field}.{name}");
        let table = spec.span();
        let spec = spec.get_ref();
        let position = self.light_position(&spec.position, &at("position"), room_size, boxes, mesh_bounds)?;
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
            (Some(points), None) => {
                let pairs: Vec<(f64, f64)> = points.get_ref().iter().map(|p| (p[0], p[1])).collect();
                let curve =
                    Curve::new(&pairs).map_err(|e| self.error(&points.span(), &at("lid"), e.to_string()))?;
                (curve, LidSource::Inline, None)
            }
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
        let optional = |value: &Option<Spanned<f64>>, name: &str, default: f64| match value {
            Some(v) => self.number(v, &at(name), 0.0, false),
            None => Ok(default),
        };
        let radius = optional(&spec.radius, "radius", 0.0)?;
        let dimmer = optional(&spec.dimmer, "dimmer", 1.0)?;
        let color = match &spec.color {
            Some(c) => {
                let rgb = self.vector(c, &at("color"))?;
                if rgb.min_element() < 0.0 {
                    return Err(self.error(&c.span(), &at("color"), "colour channels must be ≥ 0"));
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

    /// A light position: strictly inside the room, in no box and no OBJ's bounds.
    fn light_position(
        &self,
        spec: &Spanned<Vec3Spec>,
        field: &str,
        room_size: DVec3,
        boxes: &[Aabb],
        mesh_bounds: &[Aabb],
    ) -> Result<DVec3> {
        let position = self.vector(spec, field)?;
        let message = if !(position.cmpgt(DVec3::ZERO).all() && position.cmplt(room_size).all()) {
            format!(
                "the light at {:?} must be strictly inside the room (0, 0, 0) to {:?}",
                position.to_array(),
                room_size.to_array()
            )
        } else if let Some(b) = boxes.iter().position(|b| b.contains_strictly(position)) {
            format!("the light is inside box[{b}]")
        } else if let Some(m) = mesh_bounds.iter().position(|b| b.contains_strictly(position)) {
            format!("the light is inside the bounds of mesh[{m}]")
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
                let point = self.vector(target, &format!("{field}.aim"))?;
                if point == position {
                    let message = "the aim target is the light's own position";
                    return Err(self.error(&target.span(), &format!("{field}.aim"), message));
                }
                Ok(((point - position).normalize(), AimSpec::Target(point)))
            }
            (None, Some(dir)) => {
                let d = self.vector(dir, &format!("{field}.aim_dir"))?;
                if d.length_squared() == 0.0 {
                    let message = "the aim direction is zero";
                    return Err(self.error(&dir.span(), &format!("{field}.aim_dir"), message));
                }
                Ok((d.normalize(), AimSpec::Direction(d.normalize())))
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
        let file_error = |message: String| self.error(&file.span(), field, message);
        if !resolved.is_file() {
            return Err(file_error(format!(
                "photometric file `{written}` not found (resolved to `{}`)",
                resolved.display()
            )));
        }
        let lid = read_lid_file(&resolved).map_err(|e| match e {
            Error::Input(inner) if inner.place.is_empty() => {
                file_error(format!("photometric file `{written}`: {}", inner.message))
            }
            Error::Input(inner) => file_error(format!(
                "photometric file `{written}`: {}: {}",
                inner.place, inner.message
            )),
            internal @ Error::Internal(_) => internal,
        })?;
        let source = LidSource::File {
            path: resolved,
            asymmetry: lid.asymmetry,
        };
        Ok((lid.curve, source, lid.luminous))
    }

    fn settings(&self, spec: &SettingsSpec) -> Result<Settings> {
        let defaults = Settings::default();
        let positive = |value: &Option<Spanned<f64>>, name: &str, default: f64| match value {
            Some(v) => self.number(v, &format!("settings.{name}"), 0.0, true),
            None => Ok(default),
        };
        let tolerance = positive(&spec.tolerance, "tolerance", defaults.tolerance)?;
        if tolerance > 0.5 {
            let span = spec.tolerance.as_ref().map(|t| t.span()).unwrap_or_default();
            return Err(self.error(&span, "settings.tolerance", "the tolerance must be in (0, 0.5]"));
        }
        Ok(Settings {
            patch_size: positive(&spec.patch_size, "patch_size", defaults.patch_size)?,
            solver_patch_size: positive(
                &spec.solver_patch_size,
                "solver_patch_size",
                defaults.solver_patch_size,
            )?,
            direct: match spec.direct {
                Some(DirectSpec::Exact) => DirectMode::Exact,
                Some(DirectSpec::Basis) => DirectMode::Basis,
                None => defaults.direct,
            },
            tolerance,
        })
    }

    fn camera(&self, spec: &Spanned<CameraSpec>) -> Result<Camera> {
        let spec = spec.get_ref();
        let eye = self.vector(&spec.eye, "camera.eye")?;
        let target = self.vector(&spec.target, "camera.target")?;
        if eye == target {
            return Err(self.error(
                &spec.target.span(),
                "camera.target",
                "the camera target is the eye position",
            ));
        }
        let fov_deg = match &spec.fov_deg {
            Some(f) => {
                let fov = *f.get_ref();
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(self.error(
                        &f.span(),
                        "camera.fov_deg",
                        format!("{fov}° must be between 0 and 180"),
                    ));
                }
                fov
            }
            None => DEFAULT_FOV_DEG,
        };
        Ok(Camera { eye, target, fov_deg })
    }
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
