//! Calculation grids: the receivers of a calculation surface, laid out by EN 12464-1
//! (docs/ROOM_FILE.md, "Design numbers"). Each rectangle of a surface is divided into cells by
//! [`GridCells::en12464`] and gets one point at the centre of every cell, so each point stands
//! for the same area and the plain mean of the points is the area-weighted mean illuminance.
//! Points inside furniture (a box, or an OBJ mesh's bounds) are left out.

use glam::DVec3;

use crate::scene::design::{CalcSurface, GridCells, Placement};
use crate::scene::{Aabb, Scene};
use crate::transport::direct::Receiver;

/// Points are tested for furniture this far in front of their surface (m), so a point on a
/// room surface under a box, or on the work plane at a shelf's underside, counts as covered,
/// while a point on a desk top is kept.
const COVER_TEST_LIFT_M: f64 = 1e-6;

/// One rectangle of a calculation surface and its division.
#[derive(Debug, Clone, PartialEq)]
pub struct GridPart {
    /// The rectangle's name (the surface's name, or the room surface's name).
    pub name: String,
    /// The corner the cells are counted from (world, m).
    pub origin: DVec3,
    /// Edge vectors along which cells are counted (world, m): the rectangle is
    /// `origin + s·u + t·v`, s, t ∈ [0, 1].
    pub edges: [DVec3; 2],
    /// Unit normal of the receivers (the side that receives light).
    pub normal: DVec3,
    /// The division into cells.
    pub cells: GridCells,
}

impl GridPart {
    /// Centre of cell `(i, j)` (i along the first edge), world m.
    pub fn point(&self, i: usize, j: usize) -> DVec3 {
        let s = (i as f64 + 0.5) / self.cells.counts[0] as f64;
        let t = (j as f64 + 0.5) / self.cells.counts[1] as f64;
        self.origin + s * self.edges[0] + t * self.edges[1]
    }
}

/// Where a kept receiver sits: its part and cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridIndex {
    /// Index into [`CalcGrid::parts`].
    pub part: usize,
    /// Cell along the part's first edge.
    pub i: usize,
    /// Cell along the part's second edge.
    pub j: usize,
}

/// The receivers of one calculation surface.
#[derive(Debug, Clone, PartialEq)]
pub struct CalcGrid {
    /// The surface's name.
    pub name: String,
    /// Its rectangles.
    pub parts: Vec<GridPart>,
    /// The points kept, part by part, row by row (first edge fastest).
    pub receivers: Vec<Receiver>,
    /// Where each kept receiver sits (parallel to `receivers`).
    pub indices: Vec<GridIndex>,
    /// Points left out because furniture covers them.
    pub skipped_in_furniture: usize,
}

impl CalcGrid {
    /// Lays out `surface` in `scene` (the surface was validated by the loader, so every
    /// rectangle has positive edges).
    pub(crate) fn lay_out(scene: &Scene, surface: &CalcSurface) -> Self {
        let parts = parts(surface, scene.room_size);
        let furniture: Vec<&Aabb> = scene.boxes.iter().chain(&scene.mesh_bounds).collect();
        let mut grid = CalcGrid {
            name: surface.name.clone(),
            parts: Vec::new(),
            receivers: Vec::new(),
            indices: Vec::new(),
            skipped_in_furniture: 0,
        };
        for (part_index, part) in parts.into_iter().enumerate() {
            for j in 0..part.cells.counts[1] {
                for i in 0..part.cells.counts[0] {
                    let point = part.point(i, j);
                    let probe = point + part.normal * COVER_TEST_LIFT_M;
                    if furniture.iter().any(|b| b.contains_strictly(probe)) {
                        grid.skipped_in_furniture += 1;
                        continue;
                    }
                    grid.receivers.push(Receiver {
                        point,
                        normal: part.normal,
                    });
                    grid.indices.push(GridIndex {
                        part: part_index,
                        i,
                        j,
                    });
                }
            }
            grid.parts.push(part);
        }
        grid
    }
}

/// The rectangles of a surface with their EN 12464-1 divisions.
fn parts(surface: &CalcSurface, room_size: DVec3) -> Vec<GridPart> {
    match &surface.placement {
        Placement::Horizontal { height_m, min, max } => {
            let size = *max - *min;
            vec![GridPart {
                name: surface.name.clone(),
                origin: DVec3::new(min.x, min.y, *height_m),
                edges: [DVec3::X * size.x, DVec3::Y * size.y],
                normal: DVec3::Z,
                cells: GridCells::en12464(size.to_array(), surface.max_cell_m),
            }]
        }
        Placement::Room { surfaces, margin_m } => surfaces
            .iter()
            .map(|s| {
                let (origin, u, v, normal) = s.frame(room_size);
                let (lu, lv) = (u.length(), v.length());
                let (du, dv) = (u / lu, v / lv);
                let edges = [du * (lu - 2.0 * margin_m), dv * (lv - 2.0 * margin_m)];
                GridPart {
                    name: s.name().to_string(),
                    origin: origin + (du + dv) * *margin_m,
                    edges,
                    normal,
                    cells: GridCells::en12464([edges[0].length(), edges[1].length()], surface.max_cell_m),
                }
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::design::{Design, RoomSurface, Targets};
    use crate::scene::{Camera, PatchMesh, Settings};
    use glam::DVec2;

    fn scene(size: DVec3, boxes: Vec<Aabb>) -> Scene {
        Scene {
            path: "room.toml".into(),
            name: "test".into(),
            room_size: size,
            surfaces: Vec::new(),
            fine: PatchMesh::default(),
            coarse: PatchMesh::default(),
            boxes,
            mesh_bounds: Vec::new(),
            lights: Vec::new(),
            camera: Camera {
                eye: DVec3::ONE,
                target: DVec3::ZERO,
                fov_deg: 60.0,
            },
            settings: Settings::default(),
            design: Design::default_for(size),
            notes: Vec::new(),
        }
    }

    fn surface(placement: Placement, max_cell_m: Option<f64>) -> CalcSurface {
        CalcSurface {
            name: "s".into(),
            placement,
            max_cell_m,
            targets: Targets::default(),
            task: None,
        }
    }

    #[test]
    fn default_office_work_plane_is_9_by_6_points_at_cell_centres() {
        // 8 × 6 m office without the 0.5 m band: 7 × 5 m → 9 × 6 cells of 0.7778 × 0.8333 m
        // (scene::design tests); the first point sits half a cell in: x = 0.5 + 0.3889,
        // y = 0.5 + 0.4167, and the last at x = 7.5 − 0.3889, y = 5.5 − 0.4167.
        let size = DVec3::new(8.0, 6.0, 3.0);
        let s = scene(size, Vec::new());
        let grid = CalcGrid::lay_out(&s, &s.design.surfaces[0]);
        assert_eq!(grid.parts[0].cells.counts, [9, 6]);
        assert_eq!(grid.receivers.len(), 54);
        let first = grid.receivers[0].point;
        let last = grid.receivers[53].point;
        let (hx, hy) = (7.0 / 18.0, 5.0 / 12.0);
        assert!(
            (first - DVec3::new(0.5 + hx, 0.5 + hy, 0.8)).length() < 1e-12,
            "{first}"
        );
        assert!(
            (last - DVec3::new(7.5 - hx, 5.5 - hy, 0.8)).length() < 1e-12,
            "{last}"
        );
        // Row by row, x fastest: point 9 starts the second row.
        assert!((grid.receivers[9].point - DVec3::new(0.5 + hx, 0.5 + 3.0 * hy, 0.8)).length() < 1e-12);
        assert_eq!(grid.indices[10], GridIndex { part: 0, i: 1, j: 1 });
        assert!(grid.receivers.iter().all(|r| r.normal == DVec3::Z));
    }

    #[test]
    fn desk_task_area_keeps_points_on_the_desk_top_and_drops_covered_ones() {
        // A desk box 2.0–3.6 × 1.2–2.0 × 0–0.75 m; task area on its top (1.6 × 0.8 m at 0.75 m):
        // 10 × 5 cells of 0.16 m, all kept (on the top face, not inside the box).
        let desk = Aabb {
            min: DVec3::new(2.0, 1.2, 0.0),
            max: DVec3::new(3.6, 2.0, 0.75),
        };
        let s = scene(DVec3::new(8.0, 6.0, 3.0), vec![desk]);
        let top = surface(
            Placement::Horizontal {
                height_m: 0.75,
                min: DVec2::new(2.0, 1.2),
                max: DVec2::new(3.6, 2.0),
            },
            None,
        );
        let grid = CalcGrid::lay_out(&s, &top);
        assert_eq!((grid.receivers.len(), grid.skipped_in_furniture), (50, 0));
        assert!((grid.receivers[0].point - DVec3::new(2.08, 1.28, 0.75)).length() < 1e-12);
        // The same rectangle at 0.5 m runs through the desk: every point is left out.
        let inside = surface(
            Placement::Horizontal {
                height_m: 0.5,
                min: DVec2::new(2.0, 1.2),
                max: DVec2::new(3.6, 2.0),
            },
            None,
        );
        let grid = CalcGrid::lay_out(&s, &inside);
        assert_eq!((grid.receivers.len(), grid.skipped_in_furniture), (0, 50));
        // The floor under the desk is covered too: a 4 × 3 m floor with 1 m cells has 12 points;
        // the desk covers the cells centred at (2.5, 1.5) and (3.5, 1.5).
        let s = scene(DVec3::new(4.0, 3.0, 2.5), vec![desk]);
        let floor = surface(
            Placement::Room {
                surfaces: vec![RoomSurface::Floor],
                margin_m: 0.0,
            },
            Some(1.0),
        );
        let grid = CalcGrid::lay_out(&s, &floor);
        assert_eq!((grid.receivers.len(), grid.skipped_in_furniture), (10, 2));
        assert!(
            grid.receivers
                .iter()
                .all(|r| r.point.z == 0.0 && r.normal == DVec3::Z)
        );
    }

    #[test]
    fn walls_get_one_grid_each_facing_into_the_room() {
        // 4 × 3 × 2.5 m room, walls with a 0.25 m margin and 0.5 m cells:
        // wall-x0/x1 are 3 × 2.5 m → 2.5 × 2 m after the margin → d = 2.5 (ratio 1.25) →
        // 5 × 4 cells; wall-y0/y1 are 4 × 2.5 m → 3.5 × 2 m → 7 × 4 cells. 2 · 20 + 2 · 28 = 96.
        let s = scene(DVec3::new(4.0, 3.0, 2.5), Vec::new());
        let walls = surface(
            Placement::Room {
                surfaces: RoomSurface::WALLS.to_vec(),
                margin_m: 0.25,
            },
            Some(0.5),
        );
        let grid = CalcGrid::lay_out(&s, &walls);
        let counts: Vec<[usize; 2]> = grid.parts.iter().map(|p| p.cells.counts).collect();
        assert_eq!(counts, vec![[5, 4], [5, 4], [7, 4], [7, 4]]);
        assert_eq!(grid.receivers.len(), 96);
        // wall-x1 (x = 4, facing −x): first point at y = 0.25 + 0.25, z = 0.25 + 0.25.
        let x1 = &grid.parts[1];
        assert_eq!((x1.name.as_str(), x1.normal), ("wall-x1", DVec3::NEG_X));
        assert!((x1.point(0, 0) - DVec3::new(4.0, 0.5, 0.5)).length() < 1e-12);
        assert!((x1.point(4, 3) - DVec3::new(4.0, 2.5, 2.0)).length() < 1e-12);
    }
}
