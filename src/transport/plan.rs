//! The effect plan (docs/METHOD.md §7): inspect the scene and decide, with a reason for each, which effects
//! the bake simulates — visibility, interreflection, colour channels, each light's SH order, window
//! and emission mask, and whether direct light comes from the basis.

use glam::DVec3;
use serde::Serialize;

use crate::error::printable;
use crate::photometry::{Curve, Window, ZonalWeights, auto_window, sh_count, truncation_stats};
use crate::scene::{DirectMode, PatchMesh, Scene, SurfaceKind};
use crate::transport::formfactor::FormFactorOptions;
use crate::transport::hierarchy::tree_groups;
use crate::transport::interreflection::{
    COARSE_VISIBILITY_ABOVE_LEAVES, InterreflectionOptions, RELAXED_LINKS_ABOVE_LEAVES,
};
use crate::transport::refine::{RefineOptions, SolverMesh, refine};

/// Target relative L2 error of a curve's SH series when the basis carries only indirect light
/// (hybrid mode): indirect light is a smooth average of the emission, so a coarse series suffices.
pub const HYBRID_TARGET_REL_L2: f64 = 0.05;
/// Highest automatic order in hybrid mode.
pub const HYBRID_MAX_ORDER: usize = 16;
/// Target relative L2 error in paper mode (the basis carries the direct light too).
pub const BASIS_TARGET_REL_L2: f64 = 0.02;
/// Highest automatic order in paper mode.
pub const BASIS_MAX_ORDER: usize = 30;
/// A light this close to a surface (m; room surface, box face or OBJ face) counts as mounted on it.
pub const MOUNT_DISTANCE_M: f64 = 0.15;

/// One yes/no decision and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Decision {
    /// Whether the effect is simulated.
    pub on: bool,
    /// Why, in one line.
    pub reason: String,
}

/// What the bake does for one light.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LightPlan {
    /// The light's name.
    pub name: String,
    /// SH order N of its basis emitters.
    pub order: usize,
    /// Why this order.
    pub order_reason: String,
    /// Window applied to its series at relight time.
    #[serde(serialize_with = "window_name")]
    pub window: Window,
    /// Why this window.
    pub window_reason: String,
    /// Inward normal of the mounting surface when basis emitters are masked to the half-space in
    /// front of it (docs/METHOD.md §6), else `None`.
    pub mask: Option<[f64; 3]>,
    /// Why (not) masked.
    pub mask_reason: String,
    /// Basis columns per channel, (N + 1)².
    pub columns: usize,
}

fn window_name<S: serde::Serializer>(w: &Window, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(w.name())
}

/// Options that override the plan (tests force a full simulation to prove the plan changes no
/// answer).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlanOptions {
    /// Cast visibility rays even where nothing can occlude.
    pub force_visibility: bool,
    /// Solve three channels even for a grey room.
    pub force_rgb: bool,
    /// Add this to every order the plan chooses (orders fixed by the room file are the user's).
    pub order_boost: usize,
    /// Which indirect engine to use; `Auto` follows the room file's `indirect` setting (itself
    /// automatic by default: [`HIERARCHICAL_MAX_LEAVES`]).
    pub engine: EngineChoice,
}

pub use crate::scene::EngineChoice;

/// Most leaves the automatic plan gives the hierarchical engine (docs/DECISIONS.md
/// "Interreflection", "Relaxed links"): with links relaxed with distance above
/// [`RELAXED_LINKS_ABOVE_LEAVES`] its operator grows about linearly with the leaves (the
/// open-plan floor's 133 547 leaves: 16 M links, 0.56 GB, built and solved in about a minute);
/// beyond this the SH basis bake is used.
pub const HIERARCHICAL_MAX_LEAVES: usize = 250_000;

/// The plan for a scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    /// Visibility tests (shadow rays).
    pub visibility: Decision,
    /// Interreflection solve.
    pub interreflection: Decision,
    /// Colour channels solved (1 or 3).
    pub channels: usize,
    /// Why that many channels.
    pub channels_reason: String,
    /// Direct light from the basis (paper mode) instead of exact per edit.
    pub direct_basis: Decision,
    /// The indirect engine: on = the hierarchical engine (graded leaves, exact patch direct light
    /// per edit, clustered gather), off = the SH basis bake.
    pub hierarchical: Decision,
    /// Leaves of the graded solver mesh (0 when the hierarchical engine cannot be used: without
    /// interreflection, in paper mode, or with the SH basis forced).
    pub leaves: usize,
    /// One sentence per refinement of the solver mesh; empty when the scene calls for none.
    pub refinement: Vec<String>,
    /// Per light.
    pub lights: Vec<LightPlan>,
    /// Fine vertices (display mesh).
    pub fine_vertices: usize,
    /// Coarse patches (solver mesh).
    pub coarse_patches: usize,
    /// Total basis columns, Σ (N + 1)² × channels.
    pub columns: usize,
    /// Bytes of the stored basis (direct and total irradiance per column and coarse patch, f32).
    pub basis_bytes: usize,
    /// Bytes of the dense form-factor matrix (f32), 0 when there is no solve.
    pub form_factor_bytes: usize,
    /// Upper bound on the visibility rays cast to build the form factors (rays are cast only for
    /// pairs that see each other geometrically; 0 when visibility is off or there is no solve).
    pub form_factor_rays: usize,
}

/// Plans the bake of `scene`.
pub fn plan(scene: &Scene, options: PlanOptions) -> Plan {
    plan_graded(scene, options).0
}

/// [`plan`], with the graded solver mesh it made to count the leaves (refined with
/// [`RefineOptions::default`]; `None` when the hierarchical engine cannot be used), for the
/// engine to be built on without refining again ([`Interreflection::build_graded`]).
///
/// [`Interreflection::build_graded`]: crate::transport::interreflection::Interreflection::build_graded
pub fn plan_graded(scene: &Scene, options: PlanOptions) -> (Plan, Option<SolverMesh>) {
    let occluders = scene.boxes.len() + scene.mesh_bounds.len();
    let visibility = if occluders > 0 {
        Decision {
            on: true,
            reason: format!(
                "{} box(es) and {} mesh(es) can occlude; rays are traced only where a BVH bound meets the segment",
                scene.boxes.len(),
                scene.mesh_bounds.len()
            ),
        }
    } else if options.force_visibility {
        Decision {
            on: true,
            reason: "forced on (nothing can occlude in this convex room)".into(),
        }
    } else {
        Decision {
            on: false,
            reason: "the room is an empty convex box: every point sees every other".into(),
        }
    };
    let rho_max = scene
        .surfaces
        .iter()
        .map(|s| s.reflectance.max())
        .fold(0.0, f64::max);
    let interreflection = if rho_max > 0.0 {
        Decision {
            on: true,
            reason: format!(
                "reflectances up to {rho_max:.2}; solved to a certified relative error of {:.0e}",
                scene.settings.tolerance
            ),
        }
    } else {
        Decision {
            on: false,
            reason: "every reflectance is 0: no light is reflected".into(),
        }
    };
    let coloured = scene.surfaces.iter().filter(|s| !s.reflectance.is_grey()).count();
    let (channels, channels_reason) = if coloured > 0 {
        (3, format!("{coloured} surface(s) have coloured reflectance"))
    } else if options.force_rgb {
        (3, "forced to RGB (the room is grey)".into())
    } else if scene.lights.iter().any(|l| l.is_coloured()) {
        (
            1,
            "grey room: light colours scale each light's result, one channel suffices".into(),
        )
    } else {
        (1, "grey room and white lights".into())
    };
    let paper = scene.settings.direct == DirectMode::Basis;
    let direct_basis = if paper {
        Decision {
            on: true,
            reason: "direct = \"basis\" (paper mode): direct light comes from the SH series".into(),
        }
    } else {
        Decision {
            on: false,
            reason: "hybrid mode: direct light is exact at every edit, the basis carries only indirect light"
                .into(),
        }
    };
    let lights: Vec<LightPlan> = scene
        .lights
        .iter()
        .map(|l| plan_light(scene, l, options))
        .collect();
    let choice = match options.engine {
        EngineChoice::Auto => scene.settings.indirect,
        forced => forced,
    };
    // The graded mesh only matters to the hierarchical engine.
    let solver = (interreflection.on && !paper && choice != EngineChoice::Basis)
        .then(|| refine(scene, &RefineOptions::default()));
    let (leaves, refinement) = solver.as_ref().map_or((0, Vec::new()), |solver| {
        (solver.mesh.patches.len(), solver.notes(scene))
    });
    let mut hierarchical = engine_decision(choice, interreflection.on, paper, leaves);
    if let Some(solver) = solver.as_ref().filter(|_| hierarchical.on) {
        let planes = obj_planes(scene, &solver.mesh);
        if planes > MANY_OBJ_PLANES {
            hierarchical.reason += &format!(
                "; the OBJ surfaces lie in {planes} planes (curved models): their facets are \
                 linked one by one with everything closer than ten times their size, so links and \
                 bake time grow with the number of facets (a simplified model bakes faster)"
            );
        }
    }
    let n_coarse = scene.coarse.patches.len();
    let per_channel: usize = lights.iter().map(|l| l.columns).sum();
    let columns = per_channel * channels;
    let solve = interreflection.on;
    let plan = Plan {
        fine_vertices: scene.fine.n_vertices(),
        coarse_patches: n_coarse,
        columns,
        basis_bytes: if solve { 2 * columns * n_coarse * 4 } else { 0 },
        form_factor_bytes: if solve { n_coarse * n_coarse * 4 } else { 0 },
        form_factor_rays: if solve && visibility.on {
            let per_edge = FormFactorOptions::default().visibility_samples_per_edge;
            n_coarse * n_coarse * per_edge * per_edge
        } else {
            0
        },
        visibility,
        interreflection,
        channels,
        channels_reason,
        direct_basis,
        hierarchical,
        leaves,
        refinement,
        lights,
    };
    (plan, solver)
}

/// Above this many planes among the OBJ surfaces' leaves, the engine decision says what they
/// cost: each plane is a cluster tree of its own under the object's volume clusters
/// (docs/DECISIONS.md "OBJ surfaces clustered by plane", "Volume clusters"), and facets near
/// each other are linked one by one.
const MANY_OBJ_PLANES: usize = 1000;

/// Number of cluster trees the OBJ surfaces' leaves (patches of `mesh`) make: one per plane
/// they lie in, one for a flat object ([`tree_groups`]).
fn obj_planes(scene: &Scene, mesh: &PatchMesh) -> usize {
    let mut by_surface: std::collections::BTreeMap<u32, Vec<u32>> = Default::default();
    for (i, patch) in mesh.patches.iter().enumerate() {
        if matches!(
            scene.surfaces[patch.surface as usize].kind,
            SurfaceKind::Mesh { .. }
        ) {
            by_surface.entry(patch.surface).or_default().push(i as u32);
        }
    }
    by_surface
        .into_values()
        .map(|leaves| tree_groups(mesh, leaves).len())
        .sum()
}

/// Whether the hierarchical engine carries the indirect light, and why.
fn engine_decision(choice: EngineChoice, interreflection: bool, paper: bool, leaves: usize) -> Decision {
    let (on, reason) = if !interreflection {
        (false, "no interreflection to solve".to_string())
    } else if paper {
        (
            false,
            "paper mode: the SH basis carries direct and indirect light".into(),
        )
    } else {
        match choice {
            EngineChoice::Basis => (false, "forced to the SH basis bake".into()),
            EngineChoice::Hierarchical => (
                true,
                format!("forced on: {leaves} leaves{}", relaxed_links_note(leaves)),
            ),
            EngineChoice::Auto if leaves <= HIERARCHICAL_MAX_LEAVES => (
                true,
                format!(
                    "{leaves} leaves: exact patch direct light per edit, solved and gathered from the leaves{}",
                    relaxed_links_note(leaves)
                ),
            ),
            EngineChoice::Auto => (
                false,
                format!("{leaves} leaves exceed {HIERARCHICAL_MAX_LEAVES}: the SH basis bake is used"),
            ),
        }
    };
    Decision { on, reason }
}

/// What the engine's options for `leaves` leaves ([`InterreflectionOptions::for_leaves`]) change
/// of its links, as a clause of the engine decision (empty when nothing).
fn relaxed_links_note(leaves: usize) -> String {
    let links = InterreflectionOptions::for_leaves(leaves).links;
    let mut note = String::new();
    if links.eta_far > links.eta {
        note += &format!(
            "; above {RELAXED_LINKS_ABOVE_LEAVES} leaves the links relax beyond {} m (admissible ratio {} growing to {}; not those of leaves in slots) and shadow lines are not followed inside the leaves' direct light",
            links.near_m, links.eta, links.eta_far
        );
    }
    if links.visibility_refine > links.slot_visibility_refine {
        note += &format!(
            "; above {COARSE_VISIBILITY_ABOVE_LEAVES} leaves partly visible links are refined only above a form factor of {} ({} in slots)",
            links.visibility_refine, links.slot_visibility_refine
        );
    }
    note
}

/// The plan of one light of `scene` (its order — the room file's, or the lowest that meets the
/// mode's target —, window and mask), as [`plan`] makes it for each light.
pub fn plan_light(scene: &Scene, light: &crate::scene::Light, options: PlanOptions) -> LightPlan {
    let paper = scene.settings.direct == DirectMode::Basis;
    let (target, cap) = if paper {
        (BASIS_TARGET_REL_L2, BASIS_MAX_ORDER)
    } else {
        (HYBRID_TARGET_REL_L2, HYBRID_MAX_ORDER)
    };
    let (order, order_reason) = match light.order {
        Some(n) => (n, format!("fixed by the room file ({n})")),
        None => {
            let (n, reason) = choose_windowed_order(&light.curve, target, cap);
            match options.order_boost {
                0 => (n, reason),
                boost => (n + boost, format!("{reason}; raised by {boost} (forced)")),
            }
        }
    };
    let weights = ZonalWeights::exact(&light.curve, order);
    let window = auto_window(&light.curve, &weights, order);
    let window_reason = match window {
        Window::None => "the series stays above −0.5 % of the peak".to_string(),
        _ => "the series dips below −0.5 % of the peak (ringing)".to_string(),
    };
    let (mask, mask_reason) = mounting_mask(scene, light);
    LightPlan {
        name: light.name.clone(),
        order,
        order_reason,
        window,
        window_reason,
        mask: mask.map(|n| n.to_array()),
        mask_reason,
        columns: sh_count(order),
    }
}

/// The lowest order whose series, as relighting will use it (windowed when it rings, docs/METHOD.md
/// §4.4), has a relative L2 error within `target`; `cap` when none does.
fn choose_windowed_order(curve: &Curve, target: f64, cap: usize) -> (usize, String) {
    let full = ZonalWeights::exact(curve, cap);
    let mut last_error = f64::INFINITY;
    for n in 0..=cap {
        let w = full.truncated(n);
        let window = auto_window(curve, &w, n);
        last_error = truncation_stats(curve, &w, n, window).rel_l2_error;
        if last_error <= target {
            return (
                n,
                format!(
                    "lowest order whose {} series has relative L2 error ≤ {:.0} % ({:.1} %)",
                    if window == Window::None {
                        "plain"
                    } else {
                        "windowed"
                    },
                    target * 100.0,
                    last_error * 100.0
                ),
            );
        }
    }
    (
        cap,
        format!(
            "capped at {cap}: the curve needs more for {:.0} % (error {:.1} %; sharp cut-off?)",
            target * 100.0,
            last_error * 100.0
        ),
    )
}

/// The largest γ (degrees) up to which the curve can be non-zero: the end of the last segment
/// that has a non-zero end (the curve is 0 past its last point).
fn emission_reach_deg(curve: &Curve) -> f64 {
    let (g, i) = (curve.gammas_deg(), curve.intensities_cd());
    match i.iter().rposition(|&v| v > 0.0) {
        None => 0.0,
        Some(k) if k + 1 < g.len() => g[k + 1],
        Some(k) => g[k],
    }
}

/// The inward normal of the surface a light is mounted on, when its curve emits nothing behind
/// that surface for its aim: emitters are then masked to the half-space in front of it.
///
/// Any surface counts — room surfaces, box faces, OBJ faces: the light is mounted on the nearest
/// solver patch it stands in front of (or on) within [`MOUNT_DISTANCE_M`], whose polygon its
/// foot on the patch's plane lies in.
fn mounting_mask(scene: &Scene, light: &crate::scene::Light) -> (Option<DVec3>, String) {
    let p = light.position;
    let tolerance = 1e-9 * (1.0 + scene.room_size.max_element());
    let mesh = &scene.coarse;
    let nearest = mesh
        .patches
        .iter()
        .filter_map(|patch| {
            let corners: Vec<DVec3> = patch
                .vertex_ids()
                .iter()
                .map(|&v| mesh.positions[v as usize])
                .collect();
            let d = (p - corners[0]).dot(patch.normal);
            let in_front = (-tolerance..=MOUNT_DISTANCE_M).contains(&d);
            let on_patch = in_front && foot_inside(p, &corners, patch.normal, tolerance);
            on_patch.then_some((d.max(0.0), patch.normal, patch.surface))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0));
    let Some((d, n, surface)) = nearest else {
        return (
            None,
            format!("free-standing (more than {MOUNT_DISTANCE_M} m from every surface)"),
        );
    };
    let name = printable(&scene.surfaces[surface as usize].name).into_owned();
    // Largest γ at which the curve is non-zero; the mask is exact when that cone stays in front.
    let reach_deg = emission_reach_deg(&light.curve);
    // atan2 keeps the angle exact near 0 (acos loses half the digits there).
    let tilt_deg = light.aim.cross(n).length().atan2(light.aim.dot(n)).to_degrees();
    if reach_deg + tilt_deg <= 90.0 + 1e-9 {
        (
            Some(n),
            format!("mounted {d:.2} m from the {name}: emitters masked to the room side"),
        )
    } else {
        (
            None,
            format!(
                "{d:.2} m from the {name}, but the curve reaches {reach_deg:.0}° at a {tilt_deg:.0}° tilt: no mask"
            ),
        )
    }
}

/// Whether the foot of `p` on the plane of the convex polygon `corners` (unit `normal`,
/// counter-clockwise seen from the normal's side) lies inside it, within `tolerance` metres.
fn foot_inside(p: DVec3, corners: &[DVec3], normal: DVec3, tolerance: f64) -> bool {
    (0..corners.len()).all(|k| {
        let (a, b) = (corners[k], corners[(k + 1) % corners.len()]);
        (b - a).cross(p - a).dot(normal) >= -tolerance * (b - a).length()
    })
}
