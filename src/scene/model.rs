//! The loaded scene: surfaces, the two patch meshes, lights, camera and settings.
//! Plain data; built by [`crate::scene::load`], read by transport, relight and render.
//! World frame: metres, right-handed, z up (docs/METHOD.md §1).

use glam::DVec3;
use std::path::PathBuf;

use crate::photometry::{Curve, LuminousShape};
use crate::scene::design::Design;

/// Reflectance of a Lambertian surface, per channel (r, g, b), each in 0..0.98.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reflectance(pub [f64; 3]);

impl Reflectance {
    /// A grey reflectance.
    pub fn grey(rho: f64) -> Self {
        Reflectance([rho; 3])
    }
    /// True when all three channels are equal.
    pub fn is_grey(&self) -> bool {
        self.0[0] == self.0[1] && self.0[1] == self.0[2]
    }
    /// The mean of the channels (the grey equivalent).
    pub fn mean(&self) -> f64 {
        (self.0[0] + self.0[1] + self.0[2]) / 3.0
    }
    /// The largest channel.
    pub fn max(&self) -> f64 {
        self.0[0].max(self.0[1]).max(self.0[2])
    }
}

/// What a surface belongs to.
#[derive(Debug, Clone, PartialEq)]
pub enum SurfaceKind {
    /// The room's floor (z = 0), facing +z.
    Floor,
    /// The room's ceiling (z = height), facing −z.
    Ceiling,
    /// One of the room's four walls, facing into the room.
    Wall,
    /// A face of a `[[box]]` (index into the room file's boxes).
    BoxFace { box_index: usize },
    /// A triangle group of a `[[mesh]]` OBJ (index into the room file's meshes).
    Mesh { mesh_index: usize },
}

/// A surface: a planar (or OBJ) piece of geometry with one reflectance. Vertices are shared
/// within a surface and never across surfaces, so a floor/wall edge keeps two values.
#[derive(Debug, Clone)]
pub struct Surface {
    /// A name users recognise: `floor`, `ceiling`, `wall-x0` (x = 0), `wall-x1`, `wall-y0`,
    /// `wall-y1`, `box0-top`, `box0-x0`, …, `mesh0:<obj object name>`.
    pub name: String,
    /// What it belongs to.
    pub kind: SurfaceKind,
    /// Its reflectance.
    pub reflectance: Reflectance,
}

/// A patch: a planar polygon of 3 or 4 vertices (counter-clockwise seen from the side its
/// normal points to).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Patch {
    /// Vertex indices into the mesh; only the first `n_vertices` are used.
    pub vertices: [u32; 4],
    /// 3 (triangle) or 4 (quad).
    pub n_vertices: u8,
    /// Index into [`Scene::surfaces`].
    pub surface: u32,
    /// Unit normal (world frame), pointing into the room (towards where light arrives from).
    pub normal: DVec3,
    /// Area in m².
    pub area: f64,
    /// Centroid (world, m).
    pub centroid: DVec3,
}

impl Patch {
    /// The used vertex indices.
    pub fn vertex_ids(&self) -> &[u32] {
        &self.vertices[..usize::from(self.n_vertices)]
    }
}

/// A patch mesh (fine for display and direct light, coarse for interreflection).
#[derive(Debug, Clone, Default)]
pub struct PatchMesh {
    /// Vertex positions (world, m).
    pub positions: Vec<DVec3>,
    /// Per-vertex unit normal (the normal of its surface; world frame).
    pub normals: Vec<DVec3>,
    /// Per-vertex surface index.
    pub vertex_surface: Vec<u32>,
    /// The patches.
    pub patches: Vec<Patch>,
}

impl PatchMesh {
    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }
    /// Triangles `(vertex ids, patch id)`: quads split along their 0–2 diagonal.
    pub fn triangles(&self) -> impl Iterator<Item = ([u32; 3], u32)> + '_ {
        self.patches.iter().enumerate().flat_map(|(pid, p)| {
            let v = p.vertices;
            let first = ([v[0], v[1], v[2]], pid as u32);
            let second = (p.n_vertices == 4).then_some(([v[0], v[2], v[3]], pid as u32));
            std::iter::once(first).chain(second)
        })
    }
}

/// How a light's aim was given in the room file (kept so a save writes the same form back).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AimSpec {
    /// `aim = [x, y, z]`: a target point (world, m).
    Target(DVec3),
    /// `aim_dir = [x, y, z]`: a direction (normalised on load).
    Direction(DVec3),
}

/// Where a light's curve came from.
#[derive(Debug, Clone, PartialEq)]
pub enum LidSource {
    /// `lid = [[γ, cd], …]` in the room file.
    Inline,
    /// `lid_file = "…"`, resolved relative to the room file; the asymmetry of the source
    /// (max relative deviation of a C-plane from the axial average) is kept for reports.
    File { path: PathBuf, asymmetry: f64 },
}

/// A luminaire: a point (or small disc) source with an axially symmetric curve.
#[derive(Debug, Clone)]
pub struct Light {
    /// Name from the room file (unique within the room).
    pub name: String,
    /// Position (world, m).
    pub position: DVec3,
    /// Unit aim axis (world); γ = 0 points along it.
    pub aim: DVec3,
    /// The aim as written in the file.
    pub aim_spec: AimSpec,
    /// The intensity curve (cd), before the dimmer.
    pub curve: Curve,
    /// Where the curve came from.
    pub lid_source: LidSource,
    /// SH order fixed by the room file, if any.
    pub order: Option<usize>,
    /// Luminous radius `a` in metres (near-field softening `cosθ / (r² + a²)`); 0 = point source.
    pub radius: f64,
    /// Dimmer factor (multiplies the curve), ≥ 0.
    pub dimmer: f64,
    /// Colour (linear RGB multipliers, [1, 1, 1] = white).
    pub color: [f64; 3],
    /// The luminous area facing along the aim (`luminous_size`, else the photometric file's);
    /// `None` when neither gives one (glare ratings then leave the light out and say so).
    pub luminous: Option<LuminousShape>,
}

impl From<&Light> for crate::photometry::LightState {
    fn from(light: &Light) -> Self {
        crate::photometry::LightState {
            curve: light.curve.clone(),
            aim: light.aim,
            dimmer: light.dimmer,
            color: light.color,
        }
    }
}

impl Light {
    /// True when the light's colour is not white-grey (all channels equal).
    pub(crate) fn is_coloured(&self) -> bool {
        self.color[0] != self.color[1] || self.color[1] != self.color[2]
    }
}

/// The preview camera (docs/METHOD.md §1: vertical field of view; z up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position (world, m).
    pub eye: DVec3,
    /// Point looked at (world, m).
    pub target: DVec3,
    /// Vertical field of view in degrees.
    pub fov_deg: f64,
}

/// How direct light is computed (docs/METHOD.md §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DirectMode {
    /// Hybrid (default): exact direct light per edit, SH basis only for the indirect.
    #[default]
    Exact,
    /// Paper mode: direct light from the SH basis too.
    Basis,
}

/// Which engine carries the indirect light (docs/DECISIONS.md "Interreflection").
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum EngineChoice {
    /// The hierarchical engine unless the room is in paper mode or its graded mesh is above the
    /// plan's leaf budget (`transport::plan::HIERARCHICAL_MAX_LEAVES`).
    #[default]
    Auto,
    /// The SH basis bake (the seed's engine), e.g. for side-by-side tables.
    Basis,
    /// The hierarchical engine whatever its size (not in paper mode).
    Hierarchical,
}

/// `[settings]` of the room file, with defaults filled in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Fine (display) patch edge length, m. Default 0.15.
    pub patch_size: f64,
    /// Coarse (interreflection) patch edge length, m. Default 0.5.
    pub solver_patch_size: f64,
    /// Direct-light mode. Default exact (hybrid).
    pub direct: DirectMode,
    /// Certified relative error of the interreflection solve. Default 1e-3.
    pub tolerance: f64,
    /// The indirect-light engine. Default automatic.
    pub indirect: EngineChoice,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            patch_size: 0.15,
            solver_patch_size: 0.5,
            direct: DirectMode::Exact,
            tolerance: 1e-3,
            indirect: EngineChoice::Auto,
        }
    }
}

/// An axis-aligned box (furniture or obstacle), world metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: DVec3,
    /// Maximum corner.
    pub max: DVec3,
}

impl Aabb {
    /// True when `p` is strictly inside (not on the boundary).
    pub fn contains_strictly(&self, p: DVec3) -> bool {
        p.cmpgt(self.min).all() && p.cmplt(self.max).all()
    }
}

/// A point that receives light: position (world, m) and unit normal of its surface side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Receiver {
    /// Position (world, m).
    pub point: DVec3,
    /// Unit normal (world) on the side that receives light.
    pub normal: DVec3,
}

/// A loaded, meshed room.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The room file this came from.
    pub path: PathBuf,
    /// `name` from the room file.
    pub name: String,
    /// Room interior: (0, 0, 0) to `room_size`.
    pub room_size: DVec3,
    /// All surfaces; patches and vertices index into this.
    pub surfaces: Vec<Surface>,
    /// Display mesh (`patch_size`): direct light, Gouraud shading, ID buffer.
    pub fine: PatchMesh,
    /// Solver mesh (`solver_patch_size`): interreflection.
    pub coarse: PatchMesh,
    /// Boxes in the room (for the occlusion plan and bounds tests).
    pub boxes: Vec<Aabb>,
    /// Bounds of each OBJ mesh (world).
    pub mesh_bounds: Vec<Aabb>,
    /// Lights, in file order.
    pub lights: Vec<Light>,
    /// The preview camera.
    pub camera: Camera,
    /// Settings with defaults applied.
    pub settings: Settings,
    /// Calculation surfaces, glare observers and the maintenance factor.
    pub design: Design,
    /// What loading repaired in the inputs, one sentence each naming the file and the place
    /// (OBJ faces left out or turned, docs/DECISIONS.md "Degenerate and inside-out OBJ
    /// faces"): shown by `haiko plan` and `haiko bake` and when the editor opens.
    pub notes: Vec<String>,
}
