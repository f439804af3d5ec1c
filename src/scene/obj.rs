//! OBJ import (tobj): one surface per OBJ model, reflectance from the MTL `Kd`, placed in the
//! world frame (metres, z up).
//!
//! Placement: the up conversion first (`up = "y"`: (x, y, z) → (x, −z, y); `up = "z"`: kept),
//! then the uniform scale, then the translation. A model without a material, or whose material
//! has no `Kd`, gets a grey reflectance of 0.5. Polygons are split into triangle fans; a face
//! whose area is below 1e-12 m² (after placement) is an error naming its face number (1-based,
//! counted over the whole file in file order).

use glam::DVec3;
use std::path::Path;

use crate::scene::mesher::TriangleSurface;
use crate::scene::model::Reflectance;
use crate::scene::room_file::UpAxis;

/// Reflectance of OBJ models without a material or without `Kd`.
pub const DEFAULT_REFLECTANCE: f64 = 0.5;

/// Faces smaller than this (m², after placement) are rejected as degenerate.
pub const MIN_FACE_AREA: f64 = 1e-12;

/// Where an OBJ goes in the room.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// The OBJ's up axis.
    pub up: UpAxis,
    /// Uniform scale (> 0), applied after the up conversion.
    pub scale: f64,
    /// Translation (world, m), applied last.
    pub translate: DVec3,
}

impl Placement {
    /// The world position (m) of an OBJ point.
    pub fn apply(&self, p: DVec3) -> DVec3 {
        let z_up = match self.up {
            UpAxis::Y => DVec3::new(p.x, -p.z, p.y),
            UpAxis::Z => p,
        };
        z_up * self.scale + self.translate
    }
}

/// A placed OBJ surface and its reflectance.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjSurface {
    /// The triangles, world frame.
    pub geometry: TriangleSurface,
    /// From the MTL `Kd`.
    pub reflectance: Reflectance,
}

/// Reads the OBJ at `path` (which must exist) for `[[mesh]]` number `mesh_index`. The error is
/// a one-line message (without the file name, which the caller adds).
pub fn read_obj(path: &Path, mesh_index: usize, placement: &Placement) -> Result<Vec<ObjSurface>, String> {
    let options = tobj::LoadOptions {
        triangulate: false,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) =
        tobj::load_obj(path, &options).map_err(|e| format!("cannot read the OBJ: {e}"))?;
    let materials = materials.map_err(|e| format!("cannot read its material library (mtllib): {e}"))?;
    let mut surfaces = Vec::with_capacity(models.len());
    let mut faces_before = 0;
    let mut names: Vec<String> = Vec::new();
    for model in &models {
        let material = model.mesh.material_id.and_then(|id| materials.get(id));
        let reflectance = material_reflectance(material)?;
        let (triangles, n_faces) = triangulate(&model.mesh, faces_before)?;
        let positions = model
            .mesh
            .positions
            .chunks_exact(3)
            .map(|p| placement.apply(DVec3::new(widen(p[0]), widen(p[1]), widen(p[2]))))
            .collect::<Vec<_>>();
        let triangles = reject_degenerate(&positions, triangles, &model.name)?;
        faces_before += n_faces;
        let mut name = format!("mesh{mesh_index}:{}", model.name);
        if names.contains(&name) {
            name = format!("{name}#{}", surfaces.len());
        }
        names.push(name.clone());
        surfaces.push(ObjSurface {
            geometry: TriangleSurface {
                name,
                mesh_index,
                positions,
                triangles,
            },
            reflectance,
        });
    }
    Ok(surfaces)
}

/// tobj reads f32: recover the decimal as written (`0.3` → 0.3, not 0.30000001192…) through
/// the shortest decimal that rounds to the same f32.
fn widen(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(f64::from(x))
}

/// `Kd` as a reflectance; 0.5 grey without a material or `Kd`.
fn material_reflectance(material: Option<&tobj::Material>) -> Result<Reflectance, String> {
    let Some(material) = material else {
        return Ok(Reflectance::grey(DEFAULT_REFLECTANCE));
    };
    let Some(kd) = material.diffuse else {
        return Ok(Reflectance::grey(DEFAULT_REFLECTANCE));
    };
    let kd = kd.map(widen);
    if kd.iter().any(|k| !(0.0..0.98).contains(k)) {
        return Err(format!(
            "material `{}`: Kd {kd:?} must be ≥ 0 and below 0.98 (the interreflection becomes \
             singular as reflectance approaches 1)",
            material.name
        ));
    }
    Ok(Reflectance(kd))
}

/// A triangle of a face's fan.
struct FanTriangle {
    /// Vertex indices into the model's positions.
    vertices: [u32; 3],
    /// The face's 1-based number in the file.
    face: usize,
}

/// Fan-triangulates the faces of `mesh` (numbered from `faces_before + 1`); returns the
/// triangles and the number of faces.
fn triangulate(mesh: &tobj::Mesh, faces_before: usize) -> Result<(Vec<FanTriangle>, usize), String> {
    let arities: Vec<usize> = if mesh.face_arities.is_empty() {
        vec![3; mesh.indices.len() / 3]
    } else {
        mesh.face_arities.iter().map(|&a| a as usize).collect()
    };
    let mut triangles = Vec::new();
    let mut start = 0;
    for (k, &arity) in arities.iter().enumerate() {
        let face = faces_before + k + 1;
        let Some(ids) = mesh.indices.get(start..start + arity) else {
            return Err(format!("face {face}: refers to missing vertices"));
        };
        triangles.extend((2..arity).map(|c| FanTriangle {
            vertices: [ids[0], ids[c - 1], ids[c]],
            face,
        }));
        start += arity;
    }
    Ok((triangles, arities.len()))
}

/// Drops zero-area triangles of a polygon fan, but rejects a face whose total area is not a
/// finite number of at least [`MIN_FACE_AREA`].
fn reject_degenerate(
    positions: &[DVec3],
    triangles: Vec<FanTriangle>,
    object: &str,
) -> Result<Vec<[u32; 3]>, String> {
    let area = |t: &FanTriangle| {
        let [a, b, c] = t.vertices.map(|i| positions[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    };
    let mut kept = Vec::with_capacity(triangles.len());
    for face in triangles.chunk_by(|a, b| a.face == b.face) {
        let face_area: f64 = face.iter().map(area).sum();
        if !face_area.is_finite() || face_area < MIN_FACE_AREA {
            return Err(format!(
                "face {} (object `{object}`) is degenerate: area {face_area:.3e} m² after placement \
                 (it must be finite and at least {MIN_FACE_AREA:e} m²)",
                face[0].face
            ));
        }
        kept.extend(
            face.iter()
                .filter(|t| area(t) >= MIN_FACE_AREA)
                .map(|t| t.vertices),
        );
    }
    Ok(kept)
}
