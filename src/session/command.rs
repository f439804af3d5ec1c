//! Commands: the plain values that change a session's lights or camera. Applying one to a light
//! list ([`Command::apply`]) is a pure function that also returns the command that undoes it,
//! so the editor's undo stack stores commands, and the editor's model and the session's engine
//! apply the very same function to their own copies. World frame: metres, z up
//! (docs/METHOD.md §1).

use glam::{DQuat, DVec3};

use crate::photometry::{Curve, CurveError, LuminousShape};
use crate::scene::enclosure::Neighbourhood;
use crate::scene::{Aabb, AimSpec, Camera, LidSource, Scene};
use crate::session::light::{LightEdit, MAX_ORDER, WindowChoice};

/// Where lights may stand: the room's interior and the furniture they must stay out of.
#[derive(Debug, Clone, PartialEq)]
pub struct RoomBounds {
    /// Interior extent (m): from (0, 0, 0) to `size`.
    pub size: DVec3,
    /// Boxes and OBJ mesh bounds (world, m); a light strictly inside one is refused.
    pub obstacles: Vec<Aabb>,
}

impl RoomBounds {
    /// The bounds of `scene`.
    pub fn of(scene: &Scene) -> Self {
        RoomBounds {
            size: scene.room_size,
            obstacles: scene.boxes.iter().chain(&scene.mesh_bounds).copied().collect(),
        }
    }

    /// True when `position` is finite, inside the room (walls included), outside furniture and
    /// not closed in by it on every side (on a face two obstacles share).
    pub fn admits(&self, position: DVec3) -> bool {
        if !(position.is_finite()
            && position.cmpge(DVec3::ZERO).all()
            && position.cmple(self.size).all()
            && !self.obstacles.iter().any(|b| b.contains_strictly(position)))
        {
            return false;
        }
        !Neighbourhood::new(position, self.size).closed_in_by_boxes(&self.obstacles)
    }
}

/// Largest dimmer factor a command accepts (a 1000× boost is far past any real luminaire).
pub const MAX_DIMMER: f64 = 1000.0;

/// One change to a session.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Sets control point `point` of light `light`'s curve to `candela` (≥ 0).
    SetIntensity {
        /// Index of the light.
        light: usize,
        /// Index of the control point.
        point: usize,
        /// New intensity, cd.
        candela: f64,
    },
    /// Moves control point `point` of light `light`'s curve to `gamma_deg` (between its
    /// neighbours, inclusive).
    SetGamma {
        /// Index of the light.
        light: usize,
        /// Index of the control point.
        point: usize,
        /// New angle from the aim axis, degrees.
        gamma_deg: f64,
    },
    /// Replaces light `light`'s whole curve (inserted or deleted points, a new file).
    SetCurve {
        /// Index of the light.
        light: usize,
        /// The new curve (cd).
        curve: Curve,
    },
    /// Replaces light `light`'s photometry: its curve, where the curve comes from (a new
    /// photometric file) and the luminous area that file gives.
    SetPhotometry {
        /// Index of the light.
        light: usize,
        /// The new curve (cd).
        curve: Curve,
        /// Where it comes from.
        source: LidSource,
        /// The luminous area (for glare ratings), if known.
        luminous: Option<LuminousShape>,
    },
    /// Aims light `light` at a target point or along a direction.
    Aim {
        /// Index of the light.
        light: usize,
        /// The aim as the room file will say it (a direction is normalised when applied).
        spec: AimSpec,
    },
    /// Sets light `light`'s dimmer factor (0..=[`MAX_DIMMER`]).
    SetDimmer {
        /// Index of the light.
        light: usize,
        /// New factor.
        dimmer: f64,
    },
    /// Sets the SH order of light `light`'s series (0..=[`MAX_ORDER`]); needs a new bake.
    SetOrder {
        /// Index of the light.
        light: usize,
        /// New order N.
        order: usize,
    },
    /// Sets light `light`'s ringing window.
    SetWindow {
        /// Index of the light.
        light: usize,
        /// New window choice.
        window: WindowChoice,
    },
    /// Moves light `light` to `position` (world, m, inside the room); a light aimed at a
    /// target keeps aiming at it, one aimed along a direction keeps its direction. Needs a new
    /// bake of that light.
    Move {
        /// Index of the light.
        light: usize,
        /// New position (world, m).
        position: DVec3,
    },
    /// Inserts a light at index `at` (the lights from `at` on shift up by one).
    Insert {
        /// Where it goes (≤ the number of lights).
        at: usize,
        /// The light.
        light: Box<LightEdit>,
    },
    /// Removes light `light` (the lights after it shift down by one).
    Remove {
        /// Index of the light.
        light: usize,
    },
    /// Points the preview camera elsewhere.
    SetCamera(Camera),
}

/// What a command changed (what the session must recompute).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Change {
    /// One control point's intensity or angle of light `light`.
    Point {
        /// Index of the light.
        light: usize,
        /// Index of the point.
        point: usize,
    },
    /// Light `light`'s whole curve.
    Curve {
        /// Index of the light.
        light: usize,
    },
    /// Light `light`'s aim.
    Aim {
        /// Index of the light.
        light: usize,
    },
    /// Light `light`'s dimmer.
    Dimmer {
        /// Index of the light.
        light: usize,
    },
    /// Light `light`'s SH order.
    Order {
        /// Index of the light.
        light: usize,
    },
    /// Light `light`'s window.
    Window {
        /// Index of the light.
        light: usize,
    },
    /// Light `light`'s position (and, for a target aim, its axis).
    Moved {
        /// Index of the light.
        light: usize,
    },
    /// A light was inserted at `at`.
    Inserted {
        /// Its index.
        at: usize,
    },
    /// Light `at` was removed.
    Removed {
        /// Its former index.
        at: usize,
    },
    /// The camera.
    Camera,
}

impl Change {
    /// The light whose state changed (`None` for an inserted or removed light and the camera).
    pub fn light(self) -> Option<usize> {
        match self {
            Change::Point { light, .. }
            | Change::Curve { light }
            | Change::Aim { light }
            | Change::Dimmer { light }
            | Change::Order { light }
            | Change::Window { light }
            | Change::Moved { light } => Some(light),
            Change::Inserted { .. } | Change::Removed { .. } | Change::Camera => None,
        }
    }
}

/// A command that was applied: what it changed and the command that undoes it exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct Applied {
    /// What changed.
    pub change: Change,
    /// Applying this restores the state before (bit for bit).
    pub inverse: Command,
}

/// Why a command was refused (nothing changed).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CommandError {
    /// The light index is out of range.
    #[error("there is no light {light}")]
    NoLight {
        /// The index asked for.
        light: usize,
    },
    /// The control-point index is out of range.
    #[error("{light} has no control point {point}")]
    NoPoint {
        /// The light's name.
        light: String,
        /// The index asked for.
        point: usize,
    },
    /// The curve refused the change.
    #[error("{light}: {source}")]
    Curve {
        /// The light's name.
        light: String,
        /// What the curve said.
        source: CurveError,
    },
    /// An aim whose axis cannot be formed (target at the light, zero or non-finite direction).
    #[error("cannot aim {light} that way: the target is the light's own position or the direction is zero")]
    BadAim {
        /// The light's name.
        light: String,
    },
    /// A dimmer outside 0..=[`MAX_DIMMER`] or not a number.
    #[error("{light}: a dimmer of {dimmer} is outside 0 to {MAX_DIMMER}")]
    BadDimmer {
        /// The light's name.
        light: String,
        /// The value asked for.
        dimmer: f64,
    },
    /// An order above [`MAX_ORDER`].
    #[error("{light}: order {order} is above the highest, {MAX_ORDER}")]
    BadOrder {
        /// The light's name.
        light: String,
        /// The order asked for.
        order: usize,
    },
    /// A position outside the room box or not finite.
    #[error("{light}: position ({x:.3}, {y:.3}, {z:.3}) m is outside the room", x = position.x, y = position.y, z = position.z)]
    OutsideRoom {
        /// The light's name.
        light: String,
        /// The position asked for.
        position: DVec3,
    },
    /// A position inside furniture (a box or an OBJ mesh's bounds).
    #[error("{light}: position ({x:.3}, {y:.3}, {z:.3}) m is inside furniture", x = position.x, y = position.y, z = position.z)]
    Blocked {
        /// The light's name.
        light: String,
        /// The position asked for.
        position: DVec3,
    },
    /// An inserted light whose name another light already has.
    #[error("a light named {name} already exists")]
    DuplicateName {
        /// The name.
        name: String,
    },
    /// A camera whose eye is its target, or with a field of view outside (0°, 180°).
    #[error("the camera needs an eye apart from its target and a field of view between 0° and 180°")]
    BadCamera,
}

impl Command {
    /// The light a command addresses (`None` for the camera).
    pub fn light(&self) -> Option<usize> {
        match self {
            Command::SetIntensity { light, .. }
            | Command::SetGamma { light, .. }
            | Command::SetCurve { light, .. }
            | Command::SetPhotometry { light, .. }
            | Command::Aim { light, .. }
            | Command::SetDimmer { light, .. }
            | Command::SetOrder { light, .. }
            | Command::SetWindow { light, .. }
            | Command::Move { light, .. }
            | Command::Remove { light } => Some(*light),
            Command::Insert { at, .. } => Some(*at),
            Command::SetCamera(_) => None,
        }
    }

    /// Applies the command to `lights` and `camera` of a room with `bounds`, or refuses it and
    /// changes nothing.
    pub fn apply(
        &self,
        lights: &mut Vec<LightEdit>,
        camera: &mut Camera,
        bounds: &RoomBounds,
    ) -> Result<Applied, CommandError> {
        if let Command::SetCamera(new) = self {
            let valid = new.eye.is_finite()
                && new.target.is_finite()
                && new.eye != new.target
                && new.fov_deg > 0.0
                && new.fov_deg < 180.0;
            if !valid {
                return Err(CommandError::BadCamera);
            }
            let old = std::mem::replace(camera, *new);
            return Ok(Applied {
                change: Change::Camera,
                inverse: Command::SetCamera(old),
            });
        }
        if let Command::Insert { at, light } = self {
            if *at > lights.len() {
                return Err(CommandError::NoLight { light: *at });
            }
            if lights.iter().any(|l| l.name == light.name) {
                return Err(CommandError::DuplicateName {
                    name: light.name.clone(),
                });
            }
            lights.insert(*at, (**light).clone());
            return Ok(Applied {
                change: Change::Inserted { at: *at },
                inverse: Command::Remove { light: *at },
            });
        }
        let index = self.light().expect("every other command addresses a light");
        let count = lights.len();
        let light = lights
            .get_mut(index)
            .ok_or(CommandError::NoLight { light: index })?;
        let name = || light_name(light);
        let (change, inverse) = match *self {
            Command::SetIntensity { point, candela, .. } => {
                let old = point_of(light, point, light.curve.intensities_cd())?;
                light
                    .curve
                    .set_intensity(point, candela)
                    .map_err(|source| CommandError::Curve {
                        light: light.name.clone(),
                        source,
                    })?;
                (
                    Change::Point { light: index, point },
                    Command::SetIntensity {
                        light: index,
                        point,
                        candela: old,
                    },
                )
            }
            Command::SetGamma { point, gamma_deg, .. } => {
                let old = point_of(light, point, light.curve.gammas_deg())?;
                light
                    .curve
                    .set_gamma(point, gamma_deg)
                    .map_err(|source| CommandError::Curve {
                        light: light.name.clone(),
                        source,
                    })?;
                (
                    Change::Point { light: index, point },
                    Command::SetGamma {
                        light: index,
                        point,
                        gamma_deg: old,
                    },
                )
            }
            Command::SetCurve { ref curve, .. } => {
                let old = std::mem::replace(&mut light.curve, curve.clone());
                (
                    Change::Curve { light: index },
                    Command::SetCurve {
                        light: index,
                        curve: old,
                    },
                )
            }
            Command::SetPhotometry {
                ref curve,
                ref source,
                luminous,
                ..
            } => {
                let old = Command::SetPhotometry {
                    light: index,
                    curve: std::mem::replace(&mut light.curve, curve.clone()),
                    source: std::mem::replace(&mut light.lid_source, source.clone()),
                    luminous: std::mem::replace(&mut light.luminous, luminous),
                };
                (Change::Curve { light: index }, old)
            }
            Command::Aim { spec, .. } => {
                let (axis, spec) =
                    aim_axis(spec, light.position).ok_or_else(|| CommandError::BadAim { light: name() })?;
                let old = light.aim_spec;
                light.aim = axis;
                light.aim_spec = spec;
                (
                    Change::Aim { light: index },
                    Command::Aim {
                        light: index,
                        spec: old,
                    },
                )
            }
            Command::SetDimmer { dimmer, .. } => {
                if !(0.0..=MAX_DIMMER).contains(&dimmer) {
                    return Err(CommandError::BadDimmer {
                        light: name(),
                        dimmer,
                    });
                }
                let old = std::mem::replace(&mut light.dimmer, dimmer);
                (
                    Change::Dimmer { light: index },
                    Command::SetDimmer {
                        light: index,
                        dimmer: old,
                    },
                )
            }
            Command::SetOrder { order, .. } => {
                if order > MAX_ORDER {
                    return Err(CommandError::BadOrder { light: name(), order });
                }
                let old = std::mem::replace(&mut light.order, order);
                (
                    Change::Order { light: index },
                    Command::SetOrder {
                        light: index,
                        order: old,
                    },
                )
            }
            Command::SetWindow { window, .. } => {
                let old = std::mem::replace(&mut light.window, window);
                (
                    Change::Window { light: index },
                    Command::SetWindow {
                        light: index,
                        window: old,
                    },
                )
            }
            Command::Move { position, .. } => {
                if !bounds.admits(position) {
                    let light = name();
                    return Err(
                        if position.is_finite()
                            && position.cmpge(DVec3::ZERO).all()
                            && position.cmple(bounds.size).all()
                        {
                            CommandError::Blocked { light, position }
                        } else {
                            CommandError::OutsideRoom { light, position }
                        },
                    );
                }
                let old = std::mem::replace(&mut light.position, position);
                if let AimSpec::Target(target) = light.aim_spec
                    && let Some(axis) = (target - position).try_normalize()
                {
                    light.aim = axis;
                }
                (
                    Change::Moved { light: index },
                    Command::Move {
                        light: index,
                        position: old,
                    },
                )
            }
            Command::Remove { .. } => {
                let removed = lights.remove(index);
                debug_assert_eq!(lights.len() + 1, count);
                (
                    Change::Removed { at: index },
                    Command::Insert {
                        at: index,
                        light: Box::new(removed),
                    },
                )
            }
            Command::Insert { .. } | Command::SetCamera(_) => unreachable!("handled above"),
        };
        Ok(Applied { change, inverse })
    }
}

fn light_name(light: &LightEdit) -> String {
    light.name.clone()
}

/// `values[point]`, or the error naming the light and the point.
fn point_of(light: &LightEdit, point: usize, values: &[f64]) -> Result<f64, CommandError> {
    values.get(point).copied().ok_or_else(|| CommandError::NoPoint {
        light: light.name.clone(),
        point,
    })
}

/// The unit aim axis of `spec` for a light at `position`, and the spec as stored (a direction
/// normalised; a unit one kept bit for bit so that undo restores it exactly). `None` when no
/// axis can be formed.
pub fn aim_axis(spec: AimSpec, position: DVec3) -> Option<(DVec3, AimSpec)> {
    match spec {
        AimSpec::Target(point) => {
            let axis = (point - position).try_normalize()?;
            point.is_finite().then_some((axis, spec))
        }
        AimSpec::Direction(d) => {
            let unit = if (d.length_squared() - 1.0).abs() <= 4.0 * f64::EPSILON {
                d
            } else {
                d.try_normalize()?
            };
            Some((unit, AimSpec::Direction(unit)))
        }
    }
}

/// The re-aims of a group of lights aimed together (one undo step in the editor): light
/// `selected` aimed at `point` (world, m), every other light of `group` turned by the rotation
/// that takes the selected light's axis to its new one — a target stays a target, turned about
/// its light; a direction stays a direction. One entry per light of `group`, in its order, with
/// `None` where no aim is formed (the point at the selected light itself, for every light; a
/// half turn, for the others).
pub fn group_aims(
    lights: &[LightEdit],
    selected: usize,
    group: &[usize],
    point: DVec3,
) -> Vec<(usize, Option<Command>)> {
    let from = lights.get(selected).map(|light| light.aim);
    let to = lights
        .get(selected)
        .and_then(|light| (point - light.position).try_normalize());
    let rotation = from
        .zip(to)
        .filter(|(from, to)| from.dot(*to) > -1.0 + 1e-12)
        .map(|(from, to)| DQuat::from_rotation_arc(from, to));
    group
        .iter()
        .map(|&i| {
            let spec = if i == selected {
                to.map(|_| AimSpec::Target(point))
            } else {
                rotation
                    .zip(lights.get(i))
                    .map(|(rotation, light)| match light.aim_spec {
                        AimSpec::Target(t) => {
                            AimSpec::Target(light.position + rotation * (t - light.position))
                        }
                        AimSpec::Direction(d) => AimSpec::Direction(rotation * d),
                    })
            };
            (i, spec.map(|spec| Command::Aim { light: i, spec }))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::LidSource;

    fn light(name: &str) -> LightEdit {
        LightEdit {
            name: name.into(),
            position: DVec3::new(1.0, 1.0, 2.5),
            aim: DVec3::NEG_Z,
            aim_spec: AimSpec::Direction(DVec3::NEG_Z),
            curve: Curve::new(&[(0.0, 1000.0), (30.0, 900.0), (90.0, 0.0)]).unwrap(),
            lid_source: LidSource::Inline,
            dimmer: 1.0,
            order: 5,
            window: WindowChoice::Auto,
            radius_m: 0.05,
            color: [1.0; 3],
            luminous: None,
        }
    }

    fn room() -> RoomBounds {
        RoomBounds {
            size: DVec3::new(4.0, 3.0, 2.7),
            obstacles: vec![
                Aabb {
                    min: DVec3::new(3.0, 2.0, 0.0),
                    max: DVec3::new(4.0, 3.0, 1.0),
                },
                // A cabinet beside it, touching it at x = 3.
                Aabb {
                    min: DVec3::new(2.0, 2.0, 0.0),
                    max: DVec3::new(3.0, 3.0, 1.0),
                },
            ],
        }
    }

    fn camera() -> Camera {
        Camera {
            eye: DVec3::new(0.5, 0.5, 1.6),
            target: DVec3::new(2.0, 1.5, 0.8),
            fov_deg: 60.0,
        }
    }

    /// A group aimed together: the selected light aims at the point, a direction turns by the
    /// selected light's rotation, a target turns about its own light; a point at the selected
    /// light aims nobody, and a half turn leaves the others unaimed.
    #[test]
    fn a_group_turns_with_its_selected_light() {
        let selected = light("a");
        let mut beside = light("b");
        beside.position = DVec3::new(3.0, 1.0, 2.5);
        let mut targeted = light("c");
        targeted.position = DVec3::new(2.0, 2.0, 2.5);
        targeted.aim_spec = AimSpec::Target(DVec3::new(2.0, 2.0, 0.0));
        let lights = [selected, beside, targeted];
        // The selected light at (1, 1, 2.5) turns from straight down to (1, 0, -2.5)/|·|.
        let point = DVec3::new(2.0, 1.0, 0.0);
        let aims = group_aims(&lights, 0, &[0, 1, 2], point);
        let spec = |k: usize| match &aims[k] {
            (i, Some(Command::Aim { light, spec })) if *i == k && *light == k => *spec,
            other => panic!("light {k}: {other:?}"),
        };
        assert_eq!(spec(0), AimSpec::Target(point));
        let turned = DVec3::new(1.0, 0.0, -2.5).normalize();
        let AimSpec::Direction(d) = spec(1) else {
            panic!("a direction stays a direction")
        };
        assert!((d - turned).length() < 1e-12, "{d}");
        // The target 2.5 m below light c turns to 2.5 m along the turned axis.
        let AimSpec::Target(t) = spec(2) else {
            panic!("a target stays a target")
        };
        assert!(
            (t - (DVec3::new(2.0, 2.0, 2.5) + 2.5 * turned)).length() < 1e-12,
            "{t}"
        );

        let at_itself = group_aims(&lights, 0, &[0, 1], lights[0].position);
        assert!(at_itself.iter().all(|(_, c)| c.is_none()));
        let straight_up = group_aims(&lights, 0, &[0, 1], DVec3::new(1.0, 1.0, 2.7));
        assert!(matches!(straight_up[0].1, Some(Command::Aim { light: 0, .. })));
        assert!(straight_up[1].1.is_none(), "a half turn is undefined");
    }

    /// Every command, applied and then undone by its inverse, restores the lights and camera
    /// bit for bit; the change says what it touched.
    #[test]
    fn every_command_is_undone_exactly_by_its_inverse() {
        let commands = [
            Command::SetIntensity {
                light: 1,
                point: 1,
                candela: 123.456,
            },
            Command::SetGamma {
                light: 0,
                point: 1,
                gamma_deg: 41.5,
            },
            Command::SetCurve {
                light: 0,
                curve: Curve::isotropic(50.0),
            },
            Command::SetPhotometry {
                light: 1,
                curve: Curve::isotropic(75.0),
                source: LidSource::File {
                    path: "spot.ies".into(),
                    asymmetry: 0.44,
                },
                luminous: Some(LuminousShape::Ellipse {
                    length_m: 0.1,
                    width_m: 0.1,
                    side_height_m: 0.0,
                }),
            },
            Command::Aim {
                light: 1,
                spec: AimSpec::Target(DVec3::new(3.0, 2.0, 0.0)),
            },
            Command::Aim {
                light: 0,
                spec: AimSpec::Direction(DVec3::new(1.0, 1.0, -1.0)),
            },
            Command::SetDimmer {
                light: 0,
                dimmer: 0.24,
            },
            Command::SetOrder { light: 1, order: 12 },
            Command::SetWindow {
                light: 1,
                window: WindowChoice::Lanczos,
            },
            Command::Move {
                light: 0,
                position: DVec3::new(2.0, 2.0, 2.6),
            },
            Command::Insert {
                at: 1,
                light: Box::new(light("c")),
            },
            Command::Remove { light: 0 },
            Command::SetCamera(Camera {
                fov_deg: 40.0,
                ..camera()
            }),
        ];
        for command in commands {
            let mut lights = vec![light("a"), light("b")];
            lights[1].aim_spec = AimSpec::Target(DVec3::new(1.0, 1.0, 0.0));
            let mut cam = camera();
            let (before, before_cam) = (lights.clone(), cam);
            let applied = command.apply(&mut lights, &mut cam, &room()).unwrap();
            assert!(
                lights != before || cam != before_cam,
                "{command:?} changed nothing"
            );
            applied.inverse.apply(&mut lights, &mut cam, &room()).unwrap();
            assert_eq!(lights, before, "{command:?}");
            assert_eq!(cam, before_cam, "{command:?}");
        }
    }

    /// Aiming at a point sets the exact unit axis from the light; moving a light aimed at a
    /// target keeps it on the target.
    #[test]
    fn aims_and_moves_keep_the_axis_on_the_target() {
        let mut lights = vec![light("a")];
        let mut cam = camera();
        let target = DVec3::new(3.0, 2.0, 0.0);
        Command::Aim {
            light: 0,
            spec: AimSpec::Target(target),
        }
        .apply(&mut lights, &mut cam, &room())
        .unwrap();
        assert_eq!(lights[0].aim, (target - lights[0].position).normalize());
        let to = DVec3::new(0.5, 2.5, 2.0);
        Command::Move {
            light: 0,
            position: to,
        }
        .apply(&mut lights, &mut cam, &room())
        .unwrap();
        assert_eq!(lights[0].aim, (target - to).normalize());
        assert_eq!(lights[0].aim_spec, AimSpec::Target(target));
    }

    /// Refused commands name the reason and change nothing.
    #[test]
    fn lights_stand_on_free_faces_of_furniture_but_not_between_touching_pieces() {
        let bounds = room();
        // On the cabinets' tops over the face they share, and on the front of one.
        assert!(bounds.admits(DVec3::new(3.0, 2.5, 1.0)));
        assert!(bounds.admits(DVec3::new(2.5, 2.0, 0.5)));
        // On the shared face itself, and on its edge with the floor.
        assert!(!bounds.admits(DVec3::new(3.0, 2.5, 0.5)));
        assert!(!bounds.admits(DVec3::new(3.0, 2.5, 0.0)));
    }

    #[test]
    fn refused_commands_change_nothing() {
        let refused = [
            (
                Command::SetIntensity {
                    light: 0,
                    point: 9,
                    candela: 1.0,
                },
                "no control point 9",
            ),
            (
                Command::SetIntensity {
                    light: 0,
                    point: 0,
                    candela: -1.0,
                },
                "a:",
            ),
            (
                Command::SetDimmer {
                    light: 0,
                    dimmer: f64::NAN,
                },
                "dimmer",
            ),
            (
                Command::SetDimmer {
                    light: 0,
                    dimmer: 1e6,
                },
                "outside 0 to 1000",
            ),
            (Command::SetOrder { light: 0, order: 151 }, "order 151"),
            (
                Command::Move {
                    light: 0,
                    position: DVec3::new(5.0, 1.0, 1.0),
                },
                "outside the room",
            ),
            (
                Command::Aim {
                    light: 0,
                    spec: AimSpec::Target(DVec3::new(1.0, 1.0, 2.5)),
                },
                "cannot aim a",
            ),
            (
                Command::Move {
                    light: 0,
                    position: DVec3::new(3.5, 2.5, 0.5),
                },
                "inside furniture",
            ),
            (
                // On the face the two cabinets share: inside neither, closed in by both.
                Command::Move {
                    light: 0,
                    position: DVec3::new(3.0, 2.5, 0.5),
                },
                "inside furniture",
            ),
            (Command::Remove { light: 3 }, "no light 3"),
            (
                Command::Insert {
                    at: 0,
                    light: Box::new(light("a")),
                },
                "named a already",
            ),
            (
                Command::SetCamera(Camera {
                    target: camera().eye,
                    ..camera()
                }),
                "camera",
            ),
        ];
        for (command, says) in refused {
            let mut lights = vec![light("a")];
            let mut cam = camera();
            let error = command.apply(&mut lights, &mut cam, &room()).unwrap_err();
            assert!(error.to_string().contains(says), "{command:?}: {error}");
            assert_eq!(lights, vec![light("a")], "{command:?}");
            assert_eq!(cam, camera());
        }
    }
}
