//! Direct irradiance of a light's SH basis emitters on the coarse patches: the right-hand sides
//! of the interreflection solve (docs/METHOD.md §5). Emitter `(l, m)` is a point source at the light's
//! position with intensity `Y_lm(ω)` (cd, may be negative), optionally masked to the half-space in
//! front of the light's mounting surface (docs/METHOD.md §6). Values are patch averages (lx per unit
//! coefficient): the emitter's flux onto the patch by solid-angle quadrature, divided by its area,
//! so the flux is exact however close the light is.

use glam::DVec3;
use rayon::prelude::*;

use crate::photometry::{ShBasis, sh_count};
use crate::scene::PatchMesh;
use crate::transport::direct::polygon_quadrature;
use crate::transport::visibility::Visibility;

/// A light as the basis bake sees it.
#[derive(Debug, Clone, Copy)]
pub struct Emitter {
    /// Position (world, m).
    pub position: DVec3,
    /// Luminous radius (m) for the near-field softening.
    pub radius_m: f64,
    /// SH order N.
    pub order: usize,
    /// Emit only into directions `d` with `d · mask > 0` (inward normal of the mounting surface).
    pub mask: Option<DVec3>,
}

/// Patch-averaged direct irradiance of every basis emitter on every patch, patch-major:
/// `out[patch * K + k]` with `K = (N + 1)²` and `k = sh_index(l, m)` (lx per unit coefficient).
/// Visibility is tested per quadrature piece when `occluders` is given.
pub fn basis_direct(mesh: &PatchMesh, emitter: &Emitter, occluders: Option<&dyn Visibility>) -> Vec<f64> {
    let k = sh_count(emitter.order);
    let basis = ShBasis::new(emitter.order);
    let mut out = vec![0.0; mesh.patches.len() * k];
    out.par_chunks_mut(k).zip(&mesh.patches).for_each_init(
        || vec![0.0; k],
        |y, (row, patch)| {
            let polygon: Vec<DVec3> = patch
                .vertex_ids()
                .iter()
                .map(|&v| mesh.positions[v as usize])
                .collect();
            polygon_quadrature(
                emitter.position,
                emitter.radius_m,
                &polygon,
                patch.normal,
                |dir, weight, point| {
                    if emitter.mask.is_some_and(|n| dir.dot(n) <= 0.0) {
                        return;
                    }
                    if occluders.is_some_and(|v| !v.visible(emitter.position, point)) {
                        return;
                    }
                    basis.eval(dir, y);
                    for (r, &yk) in row.iter_mut().zip(y.iter()) {
                        *r += weight * yk;
                    }
                },
            );
            let inv_area = 1.0 / patch.area;
            row.iter_mut().for_each(|r| *r *= inv_area);
        },
    );
    out
}
