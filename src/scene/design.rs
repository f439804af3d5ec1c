//! What a room is designed to: calculation surfaces with their targets, glare observers and the
//! maintenance factor (docs/ROOM_FILE.md, "Design numbers"). Plain data, validated by the
//! loader; [`crate::metrics`] lays out the grids and computes the numbers.
//!
//! World frame: metres, right-handed, z up.

use glam::{DVec2, DVec3};

/// Maintenance factor when the room file gives none: the ratio of maintained to new
/// illuminance. 0.8 is a clean room with a short cleaning cycle; EN 12464-1 asks the designer
/// to state the factor used.
pub(crate) const DEFAULT_MAINTENANCE_FACTOR: f64 = 0.8;

/// Height (m) of the work plane a room without `[[surface]]` tables gets.
pub(crate) const DEFAULT_WORK_PLANE_HEIGHT_M: f64 = 0.8;

/// Band (m) along the walls left out of a work plane that covers the room (EN 12464-1).
pub(crate) const WALL_BAND_M: f64 = 0.5;

/// Eye height (m) of a seated observer (CIE 117 and EN 12464-1 use 1.2 m).
pub(crate) const SEATED_EYE_HEIGHT_M: f64 = 1.2;

/// The most grid points one calculation surface may have; more is refused with advice to raise
/// `spacing`.
pub(crate) const MAX_GRID_POINTS: usize = 1_000_000;

/// The largest grid cell EN 12464-1 allows over a calculation area whose relevant dimension is
/// `d_m` (m): `p = 0.2 · 5^log10(d)`, at most 10 m.
pub(crate) fn en12464_max_cell_m(d_m: f64) -> f64 {
    (0.2 * 5f64.powf(d_m.log10())).min(10.0)
}

/// How a rectangle is divided into grid cells: `counts[k]` cells of `cell_m[k]` along each of
/// its two edges (the calculation points sit at the cell centres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridCells {
    /// Cells (= points) along the first and the second edge.
    pub counts: [usize; 2],
    /// Cell size along each edge, m.
    pub cell_m: [f64; 2],
    /// The largest cell size the division started from, m (given, or the EN 12464-1 rule).
    pub max_cell_m: f64,
}

impl GridCells {
    /// The EN 12464-1 division of a `lengths[0] × lengths[1]` rectangle (m, both > 0): the
    /// relevant dimension d is the longer edge, or the shorter one when the longer is at least
    /// twice as long; `p` is `max_cell_m`, else [`en12464_max_cell_m`]`(d)`; d gets the nearest
    /// whole number of `d / p` cells (at least 1), and the other edge the nearest whole number
    /// of cells of the size that gives (so cells are close to square).
    pub(crate) fn en12464(lengths: [f64; 2], max_cell_m: Option<f64>) -> Self {
        let relevant = {
            let (long, short) = if lengths[0] >= lengths[1] { (0, 1) } else { (1, 0) };
            if lengths[long] >= 2.0 * lengths[short] {
                short
            } else {
                long
            }
        };
        let other = 1 - relevant;
        let p = max_cell_m.unwrap_or_else(|| en12464_max_cell_m(lengths[relevant]));
        let nearest = |x: f64| (x.round() as usize).max(1);
        let mut counts = [0; 2];
        counts[relevant] = nearest(lengths[relevant] / p);
        let cell = lengths[relevant] / counts[relevant] as f64;
        counts[other] = nearest(lengths[other] / cell);
        GridCells {
            counts,
            cell_m: [lengths[0] / counts[0] as f64, lengths[1] / counts[1] as f64],
            max_cell_m: p,
        }
    }

    /// Number of points.
    pub(crate) fn n_points(&self) -> usize {
        self.counts[0] * self.counts[1]
    }
}

/// Everything the room is designed to.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// Calculation surfaces in file order (one default work plane when the file has none).
    pub surfaces: Vec<CalcSurface>,
    /// Glare observers in file order (one per wall, at its middle, when the file has none).
    pub observers: Vec<Observer>,
    /// Maintained / new illuminance, in (0, 1].
    pub maintenance_factor: f64,
    /// True when the surfaces are the default work plane (the file has no `[[surface]]`).
    pub default_surfaces: bool,
    /// True when the observers are the defaults (the file has no `[[observer]]`).
    pub default_observers: bool,
    /// Default observers left out because furniture stands where their eyes would be, each
    /// with the reason (`wall-x0 middle (the eye is inside box[4])`).
    pub dropped_observers: Vec<String>,
}

impl Design {
    /// The default design of a room of `room_size` (m): the work plane at 0.8 m without the
    /// 0.5 m wall band, the four seated wall-middle observers, maintenance factor 0.8.
    pub fn default_for(room_size: DVec3) -> Self {
        Design {
            surfaces: vec![CalcSurface::default_work_plane(room_size)],
            observers: Observer::wall_middles(room_size),
            maintenance_factor: DEFAULT_MAINTENANCE_FACTOR,
            default_surfaces: true,
            default_observers: true,
            dropped_observers: Vec::new(),
        }
    }

    /// The UGR limit an observer is judged by: its own, else the strictest (lowest) UGR_L of
    /// the surfaces, else none.
    pub fn ugr_limit(&self, observer: &Observer) -> Option<f64> {
        observer.ugr_limit.or_else(|| {
            self.surfaces
                .iter()
                .filter_map(|s| s.targets.ugr_limit)
                .min_by(f64::total_cmp)
        })
    }
}

/// A calculation surface: a grid of receivers whose illuminance is judged against targets.
#[derive(Debug, Clone, PartialEq)]
pub struct CalcSurface {
    /// Name shown in tables.
    pub name: String,
    /// Where the grid lies.
    pub placement: Placement,
    /// Largest grid cell (m); `None` for the EN 12464-1 rule `p = 0.2 · 5^log10(d)`.
    pub max_cell_m: Option<f64>,
    /// What the surface must reach.
    pub targets: Targets,
    /// The task preset the targets came from, if any.
    pub task: Option<&'static TaskPreset>,
}

impl CalcSurface {
    /// The work plane of a room without `[[surface]]`: 0.8 m high, the room without the 0.5 m
    /// wall band (the whole room when it is narrower than 1 m), no targets.
    pub(crate) fn default_work_plane(room_size: DVec3) -> Self {
        let band = |len: f64| if len > 2.0 * WALL_BAND_M { WALL_BAND_M } else { 0.0 };
        let (bx, by) = (band(room_size.x), band(room_size.y));
        CalcSurface {
            name: "work plane".into(),
            placement: Placement::Horizontal {
                height_m: DEFAULT_WORK_PLANE_HEIGHT_M.min(room_size.z / 2.0),
                min: DVec2::new(bx, by),
                max: DVec2::new(room_size.x - bx, room_size.y - by),
            },
            max_cell_m: None,
            targets: Targets::default(),
            task: None,
        }
    }
}

/// Where a calculation surface lies.
#[derive(Debug, Clone, PartialEq)]
pub enum Placement {
    /// A horizontal rectangle facing up (a work plane or task area): `min`–`max` in x, y (m)
    /// at `height_m` above the floor.
    Horizontal {
        /// Height above the floor, m.
        height_m: f64,
        /// Corner with the smaller x and y, m.
        min: DVec2,
        /// Corner with the larger x and y, m.
        max: DVec2,
    },
    /// Room surfaces (floor, ceiling, walls), each with its own grid, minus `margin_m` along
    /// their edges; the statistics run over all their points together.
    Room {
        /// The surfaces.
        surfaces: Vec<RoomSurface>,
        /// Band along each surface's edges left out, m.
        margin_m: f64,
    },
}

/// One of the room's own surfaces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RoomSurface {
    /// z = 0, facing up.
    Floor,
    /// z = height, facing down.
    Ceiling,
    /// x = 0, facing +x.
    WallX0,
    /// x = width, facing −x.
    WallX1,
    /// y = 0, facing +y.
    WallY0,
    /// y = depth, facing −y.
    WallY1,
}

impl RoomSurface {
    /// The four walls.
    pub const WALLS: [RoomSurface; 4] = [
        RoomSurface::WallX0,
        RoomSurface::WallX1,
        RoomSurface::WallY0,
        RoomSurface::WallY1,
    ];

    /// The name used in room files and tables (the mesher's surface names).
    pub fn name(self) -> &'static str {
        match self {
            RoomSurface::Floor => "floor",
            RoomSurface::Ceiling => "ceiling",
            RoomSurface::WallX0 => "wall-x0",
            RoomSurface::WallX1 => "wall-x1",
            RoomSurface::WallY0 => "wall-y0",
            RoomSurface::WallY1 => "wall-y1",
        }
    }

    /// The surfaces a room file's `on = "…"` names: one of the names above, or `walls`.
    pub fn parse(name: &str) -> Option<Vec<RoomSurface>> {
        if name == "walls" {
            return Some(Self::WALLS.to_vec());
        }
        [
            RoomSurface::Floor,
            RoomSurface::Ceiling,
            RoomSurface::WallX0,
            RoomSurface::WallX1,
            RoomSurface::WallY0,
            RoomSurface::WallY1,
        ]
        .into_iter()
        .find(|s| s.name() == name)
        .map(|s| vec![s])
    }

    /// The surface as a rectangle in a room of `room_size`: its origin corner, the two edge
    /// vectors `u` and `v` (m) spanning it, and its unit normal into the room.
    pub fn frame(self, room_size: DVec3) -> (DVec3, DVec3, DVec3, DVec3) {
        let (w, d, h) = (room_size.x, room_size.y, room_size.z);
        match self {
            RoomSurface::Floor => (DVec3::ZERO, DVec3::X * w, DVec3::Y * d, DVec3::Z),
            RoomSurface::Ceiling => (DVec3::Z * h, DVec3::X * w, DVec3::Y * d, DVec3::NEG_Z),
            RoomSurface::WallX0 => (DVec3::ZERO, DVec3::Y * d, DVec3::Z * h, DVec3::X),
            RoomSurface::WallX1 => (DVec3::X * w, DVec3::Y * d, DVec3::Z * h, DVec3::NEG_X),
            RoomSurface::WallY0 => (DVec3::ZERO, DVec3::X * w, DVec3::Z * h, DVec3::Y),
            RoomSurface::WallY1 => (DVec3::Y * d, DVec3::X * w, DVec3::Z * h, DVec3::NEG_Y),
        }
    }
}

/// What a surface must reach; each target is optional.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Targets {
    /// Maintained mean illuminance Ē_m (lx): the maintained mean must be at least this.
    pub maintained_lux: Option<f64>,
    /// Uniformity U0 = E_min / Ē: at least this.
    pub u0: Option<f64>,
    /// Uniformity g2 = E_min / E_max: at least this.
    pub g2: Option<f64>,
    /// UGR limit UGR_L for the task: observers' UGR must not exceed it.
    pub ugr_limit: Option<f64>,
}

/// A task from EN 12464-1 with its requirements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskPreset {
    /// The name used in room files (`task = "office-writing"`).
    pub name: &'static str,
    /// Where the values come from.
    pub source: &'static str,
    /// The targets.
    pub targets: Targets,
}

const fn preset(
    name: &'static str,
    source: &'static str,
    lux: f64,
    u0: f64,
    ugr_limit: Option<f64>,
) -> TaskPreset {
    TaskPreset {
        name,
        source,
        targets: Targets {
            maintained_lux: Some(lux),
            u0: Some(u0),
            g2: None,
            ugr_limit,
        },
    }
}

/// The task presets: offices (EN 12464-1:2011 Table 5.26), corridors (Table 5.1) and the main
/// surfaces of an enclosed room (EN 12464-1:2011, walls and ceiling). Values: maintained
/// illuminance Ē_m (lx), uniformity U0 and UGR_L.
pub(crate) const TASK_PRESETS: [TaskPreset; 10] = [
    preset(
        "office-filing",
        "EN 12464-1:2011 Table 5.26, 5.26.1 filing, copying",
        300.0,
        0.40,
        Some(19.0),
    ),
    preset(
        "office-writing",
        "EN 12464-1:2011 Table 5.26, 5.26.2 writing, typing, reading, data processing",
        500.0,
        0.60,
        Some(19.0),
    ),
    preset(
        "office-drawing",
        "EN 12464-1:2011 Table 5.26, 5.26.3 technical drawing",
        750.0,
        0.70,
        Some(16.0),
    ),
    preset(
        "office-cad",
        "EN 12464-1:2011 Table 5.26, 5.26.4 CAD work stations",
        500.0,
        0.60,
        Some(19.0),
    ),
    preset(
        "office-conference",
        "EN 12464-1:2011 Table 5.26, 5.26.5 conference and meeting rooms",
        500.0,
        0.60,
        Some(19.0),
    ),
    preset(
        "office-reception",
        "EN 12464-1:2011 Table 5.26, 5.26.6 reception desk",
        300.0,
        0.60,
        Some(22.0),
    ),
    preset(
        "office-archive",
        "EN 12464-1:2011 Table 5.26, 5.26.7 archives",
        200.0,
        0.40,
        Some(25.0),
    ),
    preset(
        "corridor",
        "EN 12464-1:2011 Table 5.1, 5.1.1 circulation areas and corridors",
        100.0,
        0.40,
        Some(28.0),
    ),
    preset(
        "walls",
        "EN 12464-1:2011, main surfaces of enclosed rooms: walls",
        50.0,
        0.10,
        None,
    ),
    preset(
        "ceiling",
        "EN 12464-1:2011, main surfaces of enclosed rooms: ceiling",
        30.0,
        0.10,
        None,
    ),
];

impl TaskPreset {
    /// The preset called `name`.
    pub fn find(name: &str) -> Option<&'static TaskPreset> {
        TASK_PRESETS.iter().find(|p| p.name == name)
    }

    /// All preset names, comma-separated (for error messages).
    pub fn names() -> String {
        TASK_PRESETS.iter().map(|p| p.name).collect::<Vec<_>>().join(", ")
    }
}

/// A glare observer: eye position and horizontal line of sight.
#[derive(Debug, Clone, PartialEq)]
pub struct Observer {
    /// Name shown in tables.
    pub name: String,
    /// Eye position (world, m).
    pub eye: DVec3,
    /// Unit, horizontal line of sight (world, z = 0).
    pub view: DVec3,
    /// UGR limit for this position (overrides the surfaces' UGR_L).
    pub ugr_limit: Option<f64>,
}

impl Observer {
    /// Seated observers (eyes 1.2 m, or 40 % of a lower room's height) at the middle of each
    /// wall, looking straight across the room (the CIE 117 observer positions).
    pub(crate) fn wall_middles(room_size: DVec3) -> Vec<Observer> {
        let z = SEATED_EYE_HEIGHT_M.min(0.4 * room_size.z);
        let (w, d) = (room_size.x, room_size.y);
        [
            ("wall-y0 middle", DVec3::new(w / 2.0, 0.0, z), DVec3::Y),
            ("wall-x1 middle", DVec3::new(w, d / 2.0, z), DVec3::NEG_X),
            ("wall-y1 middle", DVec3::new(w / 2.0, d, z), DVec3::NEG_Y),
            ("wall-x0 middle", DVec3::new(0.0, d / 2.0, z), DVec3::X),
        ]
        .into_iter()
        .map(|(name, eye, view)| Observer {
            name: name.into(),
            eye,
            view,
            ugr_limit: None,
        })
        .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn en12464_cell_size_rule() {
        // p = 0.2 · 5^log10(d): d = 1 m → 0.2 m, 10 m → 1 m, 100 m → 5 m, 1000 m → 25 → 10 m.
        assert!((en12464_max_cell_m(1.0) - 0.2).abs() < 1e-15);
        assert!((en12464_max_cell_m(10.0) - 1.0).abs() < 1e-14);
        assert!((en12464_max_cell_m(100.0) - 5.0).abs() < 1e-13);
        assert_eq!(en12464_max_cell_m(1000.0), 10.0);
        // d = 5 m: 5^log10(5) = 5^0.69897 = 3.08006 → p = 0.61601 m.
        assert!((en12464_max_cell_m(5.0) - 0.616_01).abs() < 1e-5);
    }

    #[test]
    fn en12464_division_of_rectangles() {
        // 7 × 5 m (the office without its wall band): ratio 1.4 < 2, so d = 7 m,
        // p = 0.2 · 5^log10(7) = 0.2 · 5^0.845098 = 0.77934 m; 7 / 0.77934 = 8.98 → 9 cells of
        // 0.7778 m; 5 / 0.7778 = 6.43 → 6 cells of 0.8333 m.
        let g = GridCells::en12464([7.0, 5.0], None);
        assert_eq!(g.counts, [9, 6]);
        assert!((g.max_cell_m - 0.779_34).abs() < 1e-5);
        assert!((g.cell_m[0] - 7.0 / 9.0).abs() < 1e-15 && (g.cell_m[1] - 5.0 / 6.0).abs() < 1e-15);
        // 1.6 × 0.8 m desk: ratio exactly 2, so d is the shorter edge 0.8 m,
        // p = 0.2 · 5^log10(0.8) = 0.2 · 5^−0.09691 = 0.17112 m; 0.8 / 0.17112 = 4.68 → 5 cells of
        // 0.16 m; 1.6 / 0.16 = 10 cells.
        let desk = GridCells::en12464([1.6, 0.8], None);
        assert_eq!(desk.counts, [10, 5]);
        assert!((desk.max_cell_m - 0.171_12).abs() < 1e-5);
        // 2 × 2 m: p = 0.2 · 5^0.30103 = 0.32466 m; 2 / 0.32466 = 6.16 → 6 cells.
        assert_eq!(GridCells::en12464([2.0, 2.0], None).counts, [6, 6]);
        // A given spacing replaces p: 3 × 1 m with 0.25 m: d = 1 m (ratio 3) → 4 cells of
        // 0.25 m, 3 / 0.25 = 12 cells.
        let given = GridCells::en12464([3.0, 1.0], Some(0.25));
        assert_eq!((given.counts, given.max_cell_m), ([12, 4], 0.25));
        // A cell larger than the surface still gives one point.
        assert_eq!(GridCells::en12464([0.1, 0.1], Some(1.0)).counts, [1, 1]);
        assert_eq!(GridCells::en12464([7.0, 5.0], None).n_points(), 54);
    }

    #[test]
    fn office_writing_preset_is_500_lx_u0_06_ugr_19() {
        let p = TaskPreset::find("office-writing").unwrap();
        assert_eq!(p.targets.maintained_lux, Some(500.0));
        assert_eq!(p.targets.u0, Some(0.6));
        assert_eq!(p.targets.ugr_limit, Some(19.0));
        assert!(p.source.contains("5.26.2"));
        let drawing = TaskPreset::find("office-drawing").unwrap();
        assert_eq!(
            (
                drawing.targets.maintained_lux,
                drawing.targets.u0,
                drawing.targets.ugr_limit
            ),
            (Some(750.0), Some(0.7), Some(16.0))
        );
        assert!(TaskPreset::find("office").is_none());
        let names: Vec<&str> = TASK_PRESETS.iter().map(|p| p.name).collect();
        let mut unique = names.clone();
        unique.dedup();
        assert_eq!(names, unique);
    }

    #[test]
    fn default_design_is_a_banded_work_plane_and_four_wall_observers() {
        let d = Design::default_for(DVec3::new(8.0, 6.0, 3.0));
        assert_eq!(
            d.surfaces[0].placement,
            Placement::Horizontal {
                height_m: 0.8,
                min: DVec2::new(0.5, 0.5),
                max: DVec2::new(7.5, 5.5)
            }
        );
        assert_eq!(d.maintenance_factor, 0.8);
        let eyes: Vec<[f64; 3]> = d.observers.iter().map(|o| o.eye.to_array()).collect();
        assert_eq!(
            eyes,
            vec![[4.0, 0.0, 1.2], [8.0, 3.0, 1.2], [4.0, 6.0, 1.2], [0.0, 3.0, 1.2]]
        );
        // Every observer looks into the room, horizontally.
        for o in &d.observers {
            let ahead = o.eye + o.view;
            assert!(ahead.x > 0.0 && ahead.x < 8.0 && ahead.y > 0.0 && ahead.y < 6.0 && o.view.z == 0.0);
        }
        assert_eq!(d.ugr_limit(&d.observers[0]), None);
    }

    #[test]
    fn observer_limit_falls_back_to_the_strictest_surface() {
        let mut d = Design::default_for(DVec3::new(4.0, 4.0, 3.0));
        d.surfaces[0].targets.ugr_limit = Some(22.0);
        let mut second = d.surfaces[0].clone();
        second.targets.ugr_limit = Some(19.0);
        d.surfaces.push(second);
        assert_eq!(d.ugr_limit(&d.observers[0]), Some(19.0));
        d.observers[0].ugr_limit = Some(25.0);
        assert_eq!(d.ugr_limit(&d.observers[0]), Some(25.0));
    }

    #[test]
    fn room_surface_names_and_frames() {
        assert_eq!(RoomSurface::parse("walls").unwrap().len(), 4);
        assert_eq!(RoomSurface::parse("wall-x1"), Some(vec![RoomSurface::WallX1]));
        assert_eq!(RoomSurface::parse("roof"), None);
        let size = DVec3::new(8.0, 6.0, 3.0);
        let (o, u, v, n) = RoomSurface::WallY1.frame(size);
        assert_eq!(
            (o, u, v, n),
            (
                DVec3::new(0.0, 6.0, 0.0),
                DVec3::X * 8.0,
                DVec3::Z * 3.0,
                DVec3::NEG_Y
            )
        );
        let (_, u, v, n) = RoomSurface::Ceiling.frame(size);
        // The ceiling's edges span x and y; its normal points down, into the room.
        assert_eq!((u.cross(v).normalize(), n), (DVec3::Z, DVec3::NEG_Z));
    }
}
