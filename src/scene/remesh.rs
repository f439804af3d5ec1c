//! Re-meshing a loaded scene at other patch sizes (accuracy tables compare meshes without
//! re-reading the room file).
//!
//! Room surfaces and box faces are rebuilt exactly from the room size and the boxes. OBJ surfaces
//! are rebuilt from the loaded scene's coarse triangles (the same surface, already split to the
//! loaded `solver_patch_size`), so they can be refined further but not coarsened below that.

use crate::error::{Error, Result};
use crate::scene::load::MAX_VERTICES;
use crate::scene::mesher::{self, Geometry, TriangleSurface};
use crate::scene::model::{PatchMesh, Scene, SurfaceKind};

/// A copy of `scene` meshed with fine patches of edge about `patch_size` metres and coarse
/// (solver) patches of about `solver_patch_size` metres; its settings record the new sizes.
pub fn remesh(scene: &Scene, patch_size: f64, solver_patch_size: f64) -> Result<Scene> {
    for (size, field) in [
        (patch_size, "patch_size"),
        (solver_patch_size, "solver_patch_size"),
    ] {
        if !(size > 0.0 && size.is_finite()) {
            return Err(Error::input(
                &scene.path,
                format!("settings.{field}"),
                format!("{size} m must be a positive number"),
            ));
        }
    }
    let meshes = obj_surfaces(scene);
    let geometry = Geometry {
        room_size: scene.room_size,
        boxes: &scene.boxes,
        meshes: &meshes,
    };
    let layout = mesher::layout(&geometry);
    let same_surfaces = layout.len() == scene.surfaces.len()
        && layout.iter().zip(&scene.surfaces).all(|(l, s)| l.name == s.name);
    if !same_surfaces {
        return Err(Error::internal(format!(
            "{}: re-meshing produced different surfaces than loading",
            scene.path.display()
        )));
    }
    let mesh_at = |size: f64, field: &str| {
        mesher::mesh(&geometry, &layout, size, MAX_VERTICES).map_err(|too_many| {
            Error::input(
                &scene.path,
                format!("settings.{field}"),
                format!(
                    "{field} = {size} m would make about {:.0} vertices (the limit is {MAX_VERTICES})",
                    too_many.estimated
                ),
            )
        })
    };
    let mut out = scene.clone();
    out.fine = mesh_at(patch_size, "patch_size")?;
    out.coarse = mesh_at(solver_patch_size, "solver_patch_size")?;
    out.settings.patch_size = patch_size;
    out.settings.solver_patch_size = solver_patch_size;
    Ok(out)
}

/// The OBJ surfaces of `scene` as triangle surfaces, from its coarse mesh, in surface order.
fn obj_surfaces(scene: &Scene) -> Vec<TriangleSurface> {
    scene
        .surfaces
        .iter()
        .enumerate()
        .filter_map(|(id, surface)| match surface.kind {
            SurfaceKind::Mesh { mesh_index } => Some(surface_triangles(
                &scene.coarse,
                id as u32,
                surface.name.clone(),
                mesh_index,
            )),
            _ => None,
        })
        .collect()
}

/// The triangles of surface `surface_id` in `mesh`, with their own compact vertex list.
fn surface_triangles(mesh: &PatchMesh, surface_id: u32, name: String, mesh_index: usize) -> TriangleSurface {
    let mut index_of = vec![u32::MAX; mesh.n_vertices()];
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (tri, pid) in mesh.triangles() {
        if mesh.patches[pid as usize].surface != surface_id {
            continue;
        }
        triangles.push(tri.map(|v| {
            let slot = &mut index_of[v as usize];
            if *slot == u32::MAX {
                *slot = positions.len() as u32;
                positions.push(mesh.positions[v as usize]);
            }
            *slot
        }));
    }
    TriangleSurface {
        name,
        mesh_index,
        positions,
        triangles,
    }
}
