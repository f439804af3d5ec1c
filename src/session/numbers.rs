//! The design numbers of a session (docs/ROOM_FILE.md, "Design numbers"): every calculation
//! surface's maintained statistics against its targets and every observer's glare rating, for
//! the lights as they are now. The grids' receivers and the observers' eyes form one
//! [`ReceiverSet`] built on first use, so after an edit only the changed lights are recomputed
//! (docs/ARCHITECTURE.md, "Numbers"); `haiko check`, `haiko glare`, the report and the editor's
//! numbers panel all read them from here.

use crate::metrics::{
    CalcGrid, ObserverGlare, SurfaceResult, eye_receivers, glare_with, surface_grids, surface_results,
};
use crate::session::Session;
use crate::session::receivers::ReceiverSet;
use crate::transport::direct::Receiver;
use crate::transport::visibility::Visibility;

/// The receivers behind [`Session::design_numbers`]: every grid's points, then the eyes.
#[derive(Debug, Clone)]
pub(crate) struct DesignWatch {
    grids: Vec<CalcGrid>,
    /// Number of grid receivers (the eyes follow).
    n_grid: usize,
    pub(crate) set: ReceiverSet,
}

/// Every surface's and observer's numbers for the current lights.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignNumbers {
    /// The calculation surfaces, in file order, with the new illuminance at every point and the
    /// maintained statistics against the targets.
    pub surfaces: Vec<SurfaceResult>,
    /// The glare observers, in file order.
    pub observers: Vec<ObserverGlare>,
}

impl Session {
    /// The design numbers for the current lights: illuminance at every grid point by exact
    /// direct light plus, with a bake, the indirect light gathered from it (the numbers of
    /// [`Session::illuminance_at`] at the same points), and the glare rating at every observer
    /// with the background from the indirect light at the eye. The first call lays out the grids
    /// and caches their geometry; later calls recompute only the lights changed since.
    pub fn design_numbers(&mut self) -> DesignNumbers {
        let occluders = self.occluders();
        let mut design = match self.design.take() {
            Some(design) => design,
            None => {
                let grids = surface_grids(&self.scene);
                let mut receivers: Vec<Receiver> =
                    grids.iter().flat_map(|g| g.receivers.iter().copied()).collect();
                let n_grid = receivers.len();
                receivers.extend(eye_receivers(&self.scene));
                let set = self.exact_receiver_set(receivers, occluders.as_deref());
                DesignWatch { grids, n_grid, set }
            }
        };
        self.solve_indirect_or_keep();
        let inputs = super::light_inputs(
            &self.lights,
            &self.slots,
            self.bake.as_ref(),
            self.hierarchical.as_ref(),
        );
        design.set.update(&inputs, occluders.as_deref());
        let n_grid = design.n_grid;
        let grids = design.grids.clone();
        let (grid_lux, eye_indirect) = (&design.set.lux()[..n_grid], &design.set.indirect_lux()[n_grid..]);
        let surfaces = surface_results(&self.scene, grids, grid_lux);
        let vis = occluders.as_deref().map(|o| o as &dyn Visibility);
        let eye_indirect = eye_indirect.to_vec();
        self.design = Some(design);
        let scene = self.synced_scene();
        let observers = glare_with(scene, &eye_indirect, vis);
        DesignNumbers { surfaces, observers }
    }
}
