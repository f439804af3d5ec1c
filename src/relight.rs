//! The relight API the editor calls: change one light's curve, aim or dimmer and get the new
//! fine-vertex illuminance, recomputing only that light (DESIGN §3, §9).
//!
//! Each light's contribution is kept separately (lx, before colour); the RGB total is updated by
//! the difference of the edited light's old and new contribution, and re-summed from scratch every
//! [`RESUM_EVERY`] edits so rounding cannot accumulate over a long session.

use glam::DVec3;

use crate::photometry::Curve;
use crate::scene::{Light, Scene};
use crate::transport::direct::{DirectCache, Receiver};
use crate::transport::occlusion::Occluders;
use crate::transport::visibility::Visibility;

/// Edits between two full re-sums of the total.
pub const RESUM_EVERY: usize = 1024;

/// The editable state of one light: what an edit may change without a new bake.
#[derive(Debug, Clone, PartialEq)]
pub struct LightState {
    /// Intensity curve (cd).
    pub curve: Curve,
    /// Unit aim axis (world).
    pub aim: DVec3,
    /// Dimmer factor, ≥ 0.
    pub dimmer: f64,
    /// Linear RGB colour multipliers.
    pub color: [f64; 3],
}

impl From<&Light> for LightState {
    fn from(light: &Light) -> Self {
        LightState {
            curve: light.curve.clone(),
            aim: light.aim,
            dimmer: light.dimmer,
            color: light.color,
        }
    }
}

/// The receivers of a scene's fine mesh: every vertex with its surface normal.
pub fn fine_receivers(scene: &Scene) -> Vec<Receiver> {
    scene
        .fine
        .positions
        .iter()
        .zip(&scene.fine.normals)
        .map(|(&point, &normal)| Receiver { point, normal })
        .collect()
}

/// Direct illuminance of every light at the fine vertices, kept per light.
#[derive(Debug, Clone)]
pub struct Relighter {
    lights: Vec<LightState>,
    caches: Vec<DirectCache>,
    /// Per light, illuminance (lx) at each fine vertex, dimmer applied, colour not.
    per_light: Vec<Vec<f64>>,
    /// Σ over lights of colour × illuminance (lx, linear RGB) per fine vertex.
    total: Vec<[f64; 3]>,
    /// The edited light's previous values, kept to update the total by difference.
    scratch: Vec<f64>,
    edits_since_resum: usize,
}

impl Relighter {
    /// Caches the geometry of every light against the scene's fine vertices (visibility rays
    /// only when the scene has occluders) and computes the initial illuminance.
    pub fn new(scene: &Scene) -> Self {
        let occluders = Occluders::of_scene(scene);
        let receivers = fine_receivers(scene);
        let caches: Vec<DirectCache> = scene
            .lights
            .iter()
            .map(|l| {
                DirectCache::build(
                    l.position,
                    l.radius,
                    &receivers,
                    occluders.as_ref().map(|o| o as &dyn Visibility),
                )
            })
            .collect();
        let lights: Vec<LightState> = scene.lights.iter().map(LightState::from).collect();
        let n = receivers.len();
        let mut relighter = Relighter {
            per_light: vec![vec![0.0; n]; lights.len()],
            total: vec![[0.0; 3]; n],
            scratch: vec![0.0; n],
            lights,
            caches,
            edits_since_resum: 0,
        };
        for i in 0..relighter.lights.len() {
            relighter.recompute_light(i);
        }
        relighter.resum();
        relighter
    }

    /// The current state of light `i`.
    pub fn light(&self, i: usize) -> &LightState {
        &self.lights[i]
    }

    /// Number of lights.
    pub fn n_lights(&self) -> usize {
        self.lights.len()
    }

    /// Total direct illuminance per fine vertex (lx, linear RGB).
    pub fn total(&self) -> &[[f64; 3]] {
        &self.total
    }

    /// Light `i`'s direct illuminance per fine vertex (lx, dimmer applied, before colour).
    pub fn light_illuminance(&self, i: usize) -> &[f64] {
        &self.per_light[i]
    }

    /// Replaces light `i`'s curve and updates the illuminance (only that light is recomputed).
    pub fn set_curve(&mut self, i: usize, curve: Curve) {
        self.lights[i].curve = curve;
        self.update(i);
    }

    /// Re-aims light `i` along the unit vector `aim` (world).
    pub fn set_aim(&mut self, i: usize, aim: DVec3) {
        self.lights[i].aim = aim.normalize();
        self.update(i);
    }

    /// Sets light `i`'s dimmer (≥ 0).
    pub fn set_dimmer(&mut self, i: usize, dimmer: f64) {
        self.lights[i].dimmer = dimmer;
        self.update(i);
    }

    fn recompute_light(&mut self, i: usize) {
        let LightState {
            curve, aim, dimmer, ..
        } = &self.lights[i];
        self.caches[i].illuminance_into(curve, *aim, *dimmer, &mut self.per_light[i]);
    }

    fn update(&mut self, i: usize) {
        std::mem::swap(&mut self.scratch, &mut self.per_light[i]);
        self.recompute_light(i);
        let old = &self.scratch;
        self.edits_since_resum += 1;
        if self.edits_since_resum >= RESUM_EVERY {
            self.resum();
            return;
        }
        let color = self.lights[i].color;
        for ((t, &new), &old) in self.total.iter_mut().zip(&self.per_light[i]).zip(old) {
            let d = new - old;
            for c in 0..3 {
                t[c] += color[c] * d;
            }
        }
    }

    /// Re-sums the total from the per-light values.
    fn resum(&mut self) {
        self.total.iter_mut().for_each(|t| *t = [0.0; 3]);
        for (light, values) in self.lights.iter().zip(&self.per_light) {
            for (t, &e) in self.total.iter_mut().zip(values) {
                for c in 0..3 {
                    t[c] += light.color[c] * e;
                }
            }
        }
        self.edits_since_resum = 0;
    }
}
