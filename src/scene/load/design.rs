//! Validating the room file's design tables (`[[surface]]`, `[[observer]]`,
//! `settings.maintenance_factor`, a light's `luminous_size`) into [`Design`]
//! (docs/ROOM_FILE.md, "Design numbers"). Errors name the room file and `line L, column C (field)`.

use glam::{DVec2, DVec3};
use toml::Spanned;

use super::{Bounds, Loader, MAX_ROOM_SIZE_M, MIN_GRID_SPACING_M, unit};
use crate::error::Result;
use crate::photometry::LuminousShape;
use crate::photometry::luminous::MAX_LUMINOUS_SIZE_M;
use crate::scene::calc_spec::{LuminousSizeSpec, ObserverSpec, SurfaceSpec};
use crate::scene::design::{
    CalcSurface, DEFAULT_WORK_PLANE_HEIGHT_M, Design, GridCells, MAX_GRID_POINTS, Observer, Placement,
    RoomSurface, Targets, TaskPreset, WALL_BAND_M,
};
use crate::scene::model::Aabb;

/// The highest UGR a target or limit may name (CIE 117 tables stop at 30; 40 leaves room).
const MAX_UGR: f64 = 40.0;

/// The highest target illuminance, lux (ten times full sunlight).
const MAX_TARGET_LUX: f64 = 1e6;

/// What the design tables need to know about the room.
pub(super) struct RoomBounds<'a> {
    pub size: DVec3,
    pub boxes: &'a [Aabb],
    pub mesh_bounds: &'a [Aabb],
}

/// How far in front of its wall a default eye is tested for furniture, m.
const COVER_TEST_LIFT_M: f64 = 1e-6;

impl RoomBounds<'_> {
    /// `box[i]` or `the bounds of mesh[i]` when `point` is strictly inside one.
    fn covering(&self, point: DVec3) -> Option<String> {
        if let Some(b) = self.boxes.iter().position(|b| b.contains_strictly(point)) {
            return Some(format!("box[{b}]"));
        }
        self.mesh_bounds
            .iter()
            .position(|b| b.contains_strictly(point))
            .map(|m| format!("the bounds of mesh[{m}]"))
    }
}

impl Loader<'_> {
    /// The design: surfaces (default work plane when none), observers (wall middles when
    /// none) and the maintenance factor (default 0.8).
    pub(super) fn design(
        &self,
        surfaces: &[Spanned<SurfaceSpec>],
        observers: &[Spanned<ObserverSpec>],
        maintenance_factor: &Option<Spanned<f64>>,
        room: &RoomBounds,
    ) -> Result<Design> {
        let mut design = Design::default_for(room.size);
        if let Some(mf) = maintenance_factor {
            design.maintenance_factor =
                self.number(mf, "settings.maintenance_factor", Bounds::above(0.0, 1.0))?;
        }
        if !surfaces.is_empty() {
            design.surfaces = surfaces
                .iter()
                .enumerate()
                .map(|(i, s)| self.calc_surface(s, i, room))
                .collect::<Result<_>>()?;
            design.default_surfaces = false;
        }
        if observers.is_empty() {
            // A default eye that furniture covers (just in front of its wall) sees nothing.
            let (kept, dropped): (Vec<Observer>, Vec<Observer>) = design
                .observers
                .drain(..)
                .partition(|o| room.covering(o.eye + o.view * COVER_TEST_LIFT_M).is_none());
            design.dropped_observers = dropped
                .iter()
                .map(|o| {
                    let cover = room
                        .covering(o.eye + o.view * COVER_TEST_LIFT_M)
                        .unwrap_or_default();
                    format!("{} (the eye is inside {cover})", o.name)
                })
                .collect();
            design.observers = kept;
        } else {
            design.observers = observers
                .iter()
                .enumerate()
                .map(|(i, o)| self.observer(o.get_ref(), i, room))
                .collect::<Result<_>>()?;
            design.default_observers = false;
        }
        Ok(design)
    }

    fn calc_surface(
        &self,
        table: &Spanned<SurfaceSpec>,
        index: usize,
        room: &RoomBounds,
    ) -> Result<CalcSurface> {
        let spec = table.get_ref();
        let field = format!("surface[{index}]");
        let at = |name: &str| format!("{field}.{name}");
        let max_cell_m = match &spec.spacing {
            Some(s) => Some(self.number(
                s,
                &at("spacing"),
                Bounds::closed(MIN_GRID_SPACING_M, MAX_ROOM_SIZE_M),
            )?),
            None => None,
        };
        let placement = match &spec.on {
            Some(on) => self.room_surfaces(spec, on, &field, room.size)?,
            None => self.horizontal(spec, &field, room.size)?,
        };
        let n_points: usize = rectangles(&placement, room.size)
            .iter()
            .map(|lengths| GridCells::en12464(*lengths, max_cell_m).n_points())
            .sum();
        if n_points > MAX_GRID_POINTS {
            let message = format!(
                "the grid would have {n_points} points (the limit is {MAX_GRID_POINTS}); use a larger spacing"
            );
            return Err(match &spec.spacing {
                Some(s) => self.error(&s.span(), &at("spacing"), message),
                None => self.error(&table.span(), &field, message),
            });
        }
        let (task, mut targets) = match &spec.task {
            Some(name) => {
                let preset = TaskPreset::find(name.get_ref()).ok_or_else(|| {
                    let message = format!(
                        "unknown task `{}` (known: {})",
                        name.get_ref(),
                        TaskPreset::names()
                    );
                    self.error(&name.span(), &at("task"), message)
                })?;
                (Some(preset), preset.targets)
            }
            None => (None, Targets::default()),
        };
        if let Some(t) = &spec.target_lux {
            targets.maintained_lux =
                Some(self.number(t, &at("target_lux"), Bounds::above(0.0, MAX_TARGET_LUX))?);
        }
        for (value, slot, name) in [
            (&spec.target_u0, &mut targets.u0, "target_u0"),
            (&spec.target_g2, &mut targets.g2, "target_g2"),
        ] {
            if let Some(v) = value {
                *slot = Some(self.fraction(v, &at(name))?);
            }
        }
        if let Some(t) = &spec.target_ugr {
            targets.ugr_limit = Some(self.ugr(t, &at("target_ugr"))?);
        }
        let name = match (&spec.name, &spec.on) {
            (Some(n), _) => n.get_ref().clone(),
            (None, Some(on)) => on.get_ref().clone(),
            (None, None) => field.clone(),
        };
        Ok(CalcSurface {
            name,
            placement,
            max_cell_m,
            targets,
            task,
        })
    }

    /// `on = "…"`: room surfaces; a margin along their edges (default 0).
    fn room_surfaces(
        &self,
        spec: &SurfaceSpec,
        on: &Spanned<String>,
        field: &str,
        size: DVec3,
    ) -> Result<Placement> {
        for (given, name) in [
            (spec.height.as_ref().map(|h| h.span()), "height"),
            (spec.min.as_ref().map(|m| m.span()), "min"),
            (spec.max.as_ref().map(|m| m.span()), "max"),
        ] {
            if let Some(span) = given {
                let message =
                    format!("`{name}` is for a horizontal surface; a surface `on` room surfaces has none");
                return Err(self.error(&span, &format!("{field}.{name}"), message));
            }
        }
        let surfaces = RoomSurface::parse(on.get_ref()).ok_or_else(|| {
            let message = format!(
                "unknown room surface `{}` (known: floor, ceiling, walls, wall-x0, wall-x1, wall-y0, wall-y1)",
                on.get_ref()
            );
            self.error(&on.span(), &format!("{field}.on"), message)
        })?;
        let margin_m = match &spec.margin {
            Some(m) => self.number(
                m,
                &format!("{field}.margin"),
                Bounds::closed(0.0, MAX_ROOM_SIZE_M),
            )?,
            None => 0.0,
        };
        let smallest_edge = surfaces
            .iter()
            .map(|s| {
                let (_, u, v, _) = s.frame(size);
                u.length().min(v.length())
            })
            .fold(f64::INFINITY, f64::min);
        if let Some(m) = &spec.margin
            && 2.0 * margin_m >= smallest_edge
        {
            let message = format!("a margin of {margin_m} m leaves nothing of a {smallest_edge} m edge");
            return Err(self.error(&m.span(), &format!("{field}.margin"), message));
        }
        let placement = Placement::Room { surfaces, margin_m };
        Ok(placement)
    }

    /// A horizontal rectangle: `height` (default 0.8 m) inside the room; `min`/`max` together,
    /// or neither (the room without `margin`, default the 0.5 m wall band).
    fn horizontal(&self, spec: &SurfaceSpec, field: &str, size: DVec3) -> Result<Placement> {
        let at = |name: &str| format!("{field}.{name}");
        let height_m = match &spec.height {
            Some(h) => {
                let value = *h.get_ref();
                if !(value.is_finite() && value > 0.0 && value < size.z) {
                    let message = format!(
                        "the height {value} m must be above the floor and below the ceiling ({} m)",
                        size.z
                    );
                    return Err(self.error(&h.span(), &at("height"), message));
                }
                value
            }
            None => DEFAULT_WORK_PLANE_HEIGHT_M.min(size.z / 2.0),
        };
        let (min, max) = match (&spec.min, &spec.max, &spec.margin) {
            (Some(min), Some(max), None) => {
                let (lo, hi) = (self.point2(min, &at("min"))?, self.point2(max, &at("max"))?);
                if !lo.cmplt(hi).all() {
                    return Err(self.error(&max.span(), &at("max"), "max must exceed min in x and in y"));
                }
                if lo.min_element() < 0.0 || hi.x > size.x || hi.y > size.y {
                    let message = format!(
                        "the rectangle {:?} to {:?} must lie inside the room's floor plan (0, 0) to ({}, {})",
                        lo.to_array(),
                        hi.to_array(),
                        size.x,
                        size.y
                    );
                    return Err(self.error(&min.span(), &at("min"), message));
                }
                (lo, hi)
            }
            (Some(_), Some(_), Some(m)) => {
                let message = "`margin` is for a surface that covers the room; give either min/max or margin";
                return Err(self.error(&m.span(), &at("margin"), message));
            }
            (Some(one), None, _) | (None, Some(one), _) => {
                let message = "give both `min` and `max` (or neither, for the whole room)";
                return Err(self.error(&one.span(), field, message));
            }
            (None, None, margin) => {
                let margin_m = match margin {
                    Some(m) => self.number(m, &at("margin"), Bounds::closed(0.0, MAX_ROOM_SIZE_M))?,
                    None => WALL_BAND_M,
                };
                if 2.0 * margin_m >= size.x.min(size.y) {
                    let message = format!("a margin of {margin_m} m leaves no room for a grid");
                    let span = margin.as_ref().map(|m| m.span()).unwrap_or_default();
                    return Err(self.error(&span, &at("margin"), message));
                }
                (
                    DVec2::splat(margin_m),
                    DVec2::new(size.x - margin_m, size.y - margin_m),
                )
            }
        };
        Ok(Placement::Horizontal { height_m, min, max })
    }

    fn observer(&self, spec: &ObserverSpec, index: usize, room: &RoomBounds) -> Result<Observer> {
        let field = format!("observer[{index}]");
        let at = |name: &str| format!("{field}.{name}");
        let eye = self.vector(&spec.eye, &at("eye"))?;
        let size = room.size;
        let message = if !(eye.cmpge(DVec3::ZERO).all() && eye.cmple(size).all()) {
            Some(format!(
                "the eye at {:?} must be inside the room (0, 0, 0) to {:?}",
                eye.to_array(),
                size.to_array()
            ))
        } else {
            room.covering(eye)
                .map(|cover| format!("the eye is inside {cover}"))
        };
        if let Some(message) = message {
            return Err(self.error(&spec.eye.span(), &at("eye"), message));
        }
        let view = self.vector(&spec.view_dir, &at("view_dir"))?;
        let Some(view) = unit(view).filter(|v| v.z == 0.0) else {
            let message = "the line of sight must be horizontal and non-zero ([x, y, 0]): UGR (CIE 117) \
                           is defined for a horizontal line of sight";
            return Err(self.error(&spec.view_dir.span(), &at("view_dir"), message));
        };
        let ugr_limit = match &spec.ugr_limit {
            Some(u) => Some(self.ugr(u, &at("ugr_limit"))?),
            None => None,
        };
        Ok(Observer {
            name: spec.name.as_ref().map_or(field.clone(), |n| n.get_ref().clone()),
            eye,
            view,
            ugr_limit,
        })
    }

    /// A light's `luminous_size` as a shape facing along the aim.
    pub(super) fn luminous_size(
        &self,
        spec: &Spanned<LuminousSizeSpec>,
        field: &str,
    ) -> Result<LuminousShape> {
        let bad = |message: String| self.error(&spec.span(), field, message);
        let positive = |v: f64| v > 0.0 && v <= MAX_LUMINOUS_SIZE_M;
        match spec.get_ref() {
            LuminousSizeSpec::Diameter(d) if positive(*d) => Ok(LuminousShape::Ellipse {
                length_m: *d,
                width_m: *d,
                side_height_m: 0.0,
            }),
            LuminousSizeSpec::Diameter(d) => Err(bad(format!(
                "the diameter {d} m must be > 0 and ≤ {MAX_LUMINOUS_SIZE_M} m"
            ))),
            LuminousSizeSpec::Sides(sides) => match sides.as_slice() {
                &[l, w] | &[l, w, _] if !(positive(l) && positive(w)) => Err(bad(format!(
                    "length {l} m and width {w} m must be > 0 and ≤ {MAX_LUMINOUS_SIZE_M} m"
                ))),
                &[_, _, h] if !(0.0..=MAX_LUMINOUS_SIZE_M).contains(&h) => Err(bad(format!(
                    "the height {h} m must be ≥ 0 and ≤ {MAX_LUMINOUS_SIZE_M} m"
                ))),
                &[l, w] => Ok(LuminousShape::Rectangle {
                    length_m: l,
                    width_m: w,
                    side_heights_m: [0.0; 4],
                }),
                &[l, w, h] => Ok(LuminousShape::Rectangle {
                    length_m: l,
                    width_m: w,
                    side_heights_m: [h; 4],
                }),
                other => Err(bad(format!(
                    "{} numbers: give a diameter, [length, width] or [length, width, height]",
                    other.len()
                ))),
            },
        }
    }

    /// `[x, y]`: exactly two finite numbers.
    fn point2(&self, spec: &Spanned<Vec<f64>>, field: &str) -> Result<DVec2> {
        match spec.get_ref().as_slice() {
            &[x, y] if x.is_finite() && y.is_finite() => Ok(DVec2::new(x, y)),
            &[x, y] => Err(self.error(
                &spec.span(),
                field,
                format!("{:?} must be finite numbers", [x, y]),
            )),
            other => {
                let message = format!("needs exactly 2 numbers [x, y], not {}", other.len());
                Err(self.error(&spec.span(), field, message))
            }
        }
    }

    /// A ratio in (0, 1].
    fn fraction(&self, spec: &Spanned<f64>, field: &str) -> Result<f64> {
        self.number(spec, field, Bounds::above(0.0, 1.0))
    }

    /// A UGR value in (0, 40].
    fn ugr(&self, spec: &Spanned<f64>, field: &str) -> Result<f64> {
        self.number(spec, field, Bounds::above(0.0, MAX_UGR))
    }
}

/// The edge lengths `[|u|, |v|]` (m) of each rectangle a placement covers, before margins.
fn rectangles(placement: &Placement, room_size: DVec3) -> Vec<[f64; 2]> {
    match placement {
        Placement::Horizontal { min, max, .. } => vec![(*max - *min).to_array()],
        Placement::Room { surfaces, margin_m } => surfaces
            .iter()
            .map(|s| {
                let (_, u, v, _) = s.frame(room_size);
                [u.length() - 2.0 * margin_m, v.length() - 2.0 * margin_m]
            })
            .collect(),
    }
}
