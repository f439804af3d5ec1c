//! The bake (docs/METHOD.md §5, §7): per light, the indirect irradiance of every SH basis emitter
//! on the coarse patches, with interreflection solved to a certified tolerance, cached on disk per
//! light.
//!
//! For light `i` with order N the basis has `K = (N + 1)²` emitters; column `k = sh_index(l, m)`
//! is the room's response to a point source of intensity `Y_lm(ω)` at the light (masked to the
//! mounting half-space when the plan says so). Stored per column and coarse patch (f32):
//! the patch-averaged direct irradiance `E_k` and the indirect irradiance `H_k − E_k` per channel
//! (lx per unit coefficient). Relighting blends them with `c_k = w_l 4π/(2l+1) Y_lm(aim)`.
//!
//! The work splits in two: a [`Transport`] holds what every light's bake shares (the coarse mesh,
//! reflectances, occluders and the balanced form factors, built on first need) and is `Send +
//! Sync`, so one moved light can be re-baked on a background thread ([`Transport::bake_lights`])
//! while the other lights stay editable; [`bake`] plans a scene and bakes all its lights.

use std::sync::{Arc, OnceLock};
use std::time::Instant;

use glam::DVec3;

use crate::error::{Error, Result};
use crate::scene::{Light, PatchMesh, Scene};
use crate::transport::basis::{Emitter, basis_direct};
use crate::transport::cache::{self, BakeCache, CacheLoad, Fnv64, ValueSink, ValueSource};
use crate::transport::formfactor::{FormFactorOptions, FormFactors};
use crate::transport::occlusion::{Occluders, hash_occluders};
use crate::transport::plan::{LightPlan, Plan, PlanOptions, plan};
use crate::transport::radiosity::{PatchColumns, SolveOptions, solve};
use crate::transport::visibility::{Unoccluded, Visibility};

/// One light's baked basis.
#[derive(Debug, Clone, PartialEq)]
pub struct BakedLight {
    /// The light's plan (order, window, mask and reasons).
    pub plan: LightPlan,
    /// Columns K = (N + 1)².
    pub n_columns: usize,
    /// Patch-averaged direct irradiance per coarse patch and column, patch-major (lx per unit
    /// coefficient). Empty when there is no interreflection.
    pub direct: Vec<f32>,
    /// Indirect irradiance `H − E` per channel, each patch-major like `direct`. Empty when there
    /// is no interreflection.
    pub indirect: Vec<Vec<f32>>,
    /// Largest GMRES iteration count over this light's columns (0 if loaded or no solve).
    pub iterations: usize,
    /// Largest certified relative error bound `‖B̃ − B‖∞ / ‖B̃‖∞` over the columns.
    pub certified_error: f64,
    /// True when it came from the cache.
    pub from_cache: bool,
}

impl BakedLight {
    /// True when the light has a stored indirect basis.
    pub fn has_indirect(&self) -> bool {
        !self.indirect.is_empty()
    }
}

/// Wall time of each bake stage, seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BakeTimings {
    /// Planning.
    pub plan_s: f64,
    /// Reading the cache.
    pub cache_read_s: f64,
    /// Form factors (with visibility rays when planned).
    pub form_factors_s: f64,
    /// Direct irradiance of the basis emitters on the coarse patches.
    pub basis_direct_s: f64,
    /// The block solve.
    pub solve_s: f64,
    /// Writing the cache.
    pub cache_write_s: f64,
}

/// A finished bake.
#[derive(Debug, Clone)]
pub struct Bake {
    /// The plan it followed.
    pub plan: Plan,
    /// The shared transport operator, for re-baking single lights later.
    pub transport: Arc<Transport>,
    /// Per light, in scene order.
    pub lights: Vec<BakedLight>,
    /// Stage timings.
    pub timings: BakeTimings,
    /// One-line notices (a stale or corrupt cache file that was rebuilt, a cache that could not
    /// be written).
    pub notices: Vec<String>,
    /// Visibility rays cast for the form factors.
    pub form_factor_rays: u64,
    /// Bytes of the form-factor matrix (0 when none was built).
    pub form_factor_bytes: usize,
}

/// How to bake.
#[derive(Debug, Clone, Default)]
pub struct BakeOptions {
    /// Plan overrides (tests force a full simulation).
    pub plan: PlanOptions,
    /// The cache; `None` bakes without reading or writing one.
    pub cache: Option<BakeCache>,
    /// Overrides the room's solver tolerance (accuracy tables).
    pub tolerance: Option<f64>,
    /// Form-factor options (near-field rule, rays per pair); default from [`FormFactorOptions`].
    pub form_factors: Option<FormFactorOptions>,
}

/// Progress of a bake: `done` of `total` work units in the named stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// Stage name.
    pub stage: &'static str,
    /// Units done.
    pub done: usize,
    /// Units in the stage.
    pub total: usize,
}

/// The bake's form factors: the exact contour formula for every pair (the differential far-field
/// rule leaves row sums off by up to 3e-3, which a ρ = 0.95 room amplifies twentyfold).
pub fn default_form_factor_options() -> FormFactorOptions {
    FormFactorOptions {
        near_field_ratio: f64::INFINITY,
        ..FormFactorOptions::default()
    }
}

/// Reflectance of each coarse patch in channel `c`.
pub fn patch_reflectance(scene: &Scene, mesh: &PatchMesh, channel: usize) -> Vec<f64> {
    mesh.patches
        .iter()
        .map(|p| scene.surfaces[p.surface as usize].reflectance.0[channel])
        .collect()
}

/// What the bake of one light depends on besides the room: its position, luminous radius and
/// plan (order, mask).
#[derive(Debug, Clone, PartialEq)]
pub struct LightBakeSpec {
    /// Position (world, m).
    pub position: DVec3,
    /// Luminous radius (m).
    pub radius_m: f64,
    /// The light's plan.
    pub plan: LightPlan,
}

impl LightBakeSpec {
    /// The spec of `light` under `plan`.
    pub fn new(light: &Light, plan: &LightPlan) -> Self {
        LightBakeSpec {
            position: light.position,
            radius_m: light.radius,
            plan: plan.clone(),
        }
    }

    fn emitter(&self) -> Emitter {
        Emitter {
            position: self.position,
            radius_m: self.radius_m,
            order: self.plan.order,
            mask: self.plan.mask.map(DVec3::from),
        }
    }
}

/// What every light's bake shares: the coarse mesh, its reflectances, the occluders and (built
/// on first need) the balanced form factors. Thread-safe; cheap to keep for a session.
#[derive(Debug)]
pub struct Transport {
    coarse: PatchMesh,
    /// Reflectance per channel, one value per coarse patch.
    reflectance: Vec<Vec<f64>>,
    occluders: Option<Arc<Occluders>>,
    visibility: bool,
    interreflection: bool,
    channels: usize,
    tolerance: f64,
    form_factor_options: FormFactorOptions,
    /// Hash of everything above that a light's cache key depends on.
    room_key: u64,
    form_factors: OnceLock<FormFactors>,
}

/// What [`Transport::bake_lights`] did besides the baked lights.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BakeReport {
    /// Stage timings (`plan_s` is left 0).
    pub timings: BakeTimings,
    /// One-line notices (cache files rebuilt or not written).
    pub notices: Vec<String>,
}

impl Transport {
    /// The transport of `scene` under `plan`; `occluders` as [`Occluders::of_scene`] (shared with
    /// the direct light). The form factors are built by the first bake that needs them.
    pub fn new(scene: &Scene, plan: &Plan, options: &BakeOptions, occluders: Option<Arc<Occluders>>) -> Self {
        let tolerance = options.tolerance.unwrap_or(scene.settings.tolerance);
        let form_factor_options = options.form_factors.unwrap_or_else(default_form_factor_options);
        let mut transport = Transport {
            reflectance: (0..3)
                .map(|c| patch_reflectance(scene, &scene.coarse, c))
                .collect(),
            coarse: scene.coarse.clone(),
            occluders,
            visibility: plan.visibility.on,
            interreflection: plan.interreflection.on,
            channels: plan.channels,
            tolerance,
            form_factor_options,
            room_key: 0,
            form_factors: OnceLock::new(),
        };
        transport.room_key = room_key(scene, &transport);
        transport
    }

    /// The scene's occluders (None in an empty convex room).
    pub fn occluders(&self) -> Option<&Arc<Occluders>> {
        self.occluders.as_ref()
    }

    /// Number of coarse patches.
    pub fn n_patches(&self) -> usize {
        self.coarse.patches.len()
    }

    /// The cache key of a light's bake: everything its baked columns depend on.
    pub fn light_key(&self, light: &LightBakeSpec) -> u64 {
        let mut h = Fnv64::default();
        h.u64(self.room_key);
        h.f64(light.position.x)
            .f64(light.position.y)
            .f64(light.position.z)
            .f64(light.radius_m);
        h.u64(light.plan.order as u64);
        match light.plan.mask {
            Some(n) => h.u64(1).f64(n[0]).f64(n[1]).f64(n[2]),
            None => h.u64(0),
        };
        h.finish()
    }

    /// Visibility rays cast and bytes held by the form factors (0, 0 before they are built).
    pub fn form_factor_stats(&self) -> (u64, usize) {
        self.form_factors
            .get()
            .map_or((0, 0), |f| (f.rays_cast(), f.bytes()))
    }

    /// The balanced form factors, built now if no bake needed them before; with the seconds
    /// spent building them in this call.
    fn form_factors(&self, progress: &mut dyn FnMut(Progress)) -> (&FormFactors, f64) {
        let mut built_now = 0.0;
        let built = self.form_factors.get_or_init(|| {
            let n = self.n_patches();
            progress(Progress {
                stage: "form factors",
                done: 0,
                total: n,
            });
            let t = Instant::now();
            let occluders = self.visibility.then(|| {
                self.occluders
                    .clone()
                    .unwrap_or_else(|| Arc::new(Occluders::from_parts(&[], &[])))
            });
            let mut matrix = match &occluders {
                Some(occ) => FormFactors::build(&self.coarse, occ.as_ref(), self.form_factor_options),
                None => FormFactors::build(&self.coarse, &Unoccluded, self.form_factor_options),
            };
            let areas: Vec<f64> = self.coarse.patches.iter().map(|p| p.area).collect();
            matrix.balance(&areas);
            built_now = t.elapsed().as_secs_f64();
            progress(Progress {
                stage: "form factors",
                done: n,
                total: n,
            });
            matrix
        });
        (built, built_now)
    }

    /// Bakes `lights` (or loads them from `cache`): one block solve over the columns of every
    /// light the cache does not hold. Progress is reported per stage.
    ///
    /// Errors: the interreflection solve failing (internal).
    pub fn bake_lights(
        &self,
        lights: &[LightBakeSpec],
        cache: Option<&BakeCache>,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<(Vec<BakedLight>, BakeReport)> {
        let n = self.n_patches();
        let mut report = BakeReport::default();
        let t = Instant::now();
        let keys: Vec<u64> = lights.iter().map(|l| self.light_key(l)).collect();
        let mut baked: Vec<Option<BakedLight>> = vec![None; lights.len()];
        if let Some(cache) = cache {
            for (i, &key) in keys.iter().enumerate() {
                match cache.read_with(key, |r| decode(r, &lights[i].plan, n)) {
                    CacheLoad::Hit(light) => baked[i] = Some(light),
                    CacheLoad::Missing => {}
                    CacheLoad::Invalid(why) => report.notices.push(format!("cache {why}; rebuilding")),
                }
            }
        }
        report.timings.cache_read_s = t.elapsed().as_secs_f64();
        let todo: Vec<usize> = (0..lights.len()).filter(|&i| baked[i].is_none()).collect();
        if !self.interreflection {
            for &i in &todo {
                baked[i] = Some(BakedLight::without_indirect(&lights[i].plan));
            }
        } else if !todo.is_empty() {
            let specs: Vec<&LightBakeSpec> = todo.iter().map(|&i| &lights[i]).collect();
            for (&i, light) in todo
                .iter()
                .zip(self.solve_lights(&specs, &mut report.timings, progress)?)
            {
                baked[i] = Some(light);
            }
        }
        let t = Instant::now();
        if let Some(cache) = cache {
            for &i in &todo {
                let light = baked[i].as_ref().expect("every light to bake was baked");
                if let Err(e) = cache.write_with(keys[i], |w| encode(w, light)) {
                    report.notices.push(format!(
                        "could not write the bake cache in {}: {e}",
                        cache.dir.display()
                    ));
                }
            }
        }
        report.timings.cache_write_s = t.elapsed().as_secs_f64();
        let baked = baked
            .into_iter()
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| Error::internal("a light was not baked"))?;
        Ok((baked, report))
    }

    /// The basis direct light of `lights` and one block solve over all their columns, per channel.
    fn solve_lights(
        &self,
        lights: &[&LightBakeSpec],
        timings: &mut BakeTimings,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<Vec<BakedLight>> {
        let n = self.n_patches();
        let (ff, ff_seconds) = self.form_factors(progress);
        timings.form_factors_s = ff_seconds;

        let t = Instant::now();
        let vis = self
            .occluders
            .as_deref()
            .filter(|_| self.visibility)
            .map(|o| o as &dyn Visibility);
        let mut directs = Vec::with_capacity(lights.len());
        for (done, light) in lights.iter().enumerate() {
            progress(Progress {
                stage: "basis direct light",
                done,
                total: lights.len(),
            });
            directs.push(basis_direct(&self.coarse, &light.emitter(), vis));
        }
        progress(Progress {
            stage: "basis direct light",
            done: lights.len(),
            total: lights.len(),
        });
        timings.basis_direct_s = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let widths: Vec<usize> = lights.iter().map(|l| l.plan.columns).collect();
        let total_k: usize = widths.iter().sum();
        let mut block = PatchColumns::zeros(n, total_k);
        let mut offset = 0;
        for (direct, &k) in directs.iter().zip(&widths) {
            for p in 0..n {
                block.values[p * total_k + offset..p * total_k + offset + k]
                    .copy_from_slice(&direct[p * k..(p + 1) * k]);
            }
            offset += k;
        }
        let solve_options = SolveOptions {
            tolerance: self.tolerance,
            ..SolveOptions::default()
        };
        let mut indirect_by_channel = Vec::with_capacity(self.channels);
        let mut reports = Vec::with_capacity(self.channels);
        for channel in 0..self.channels {
            progress(Progress {
                stage: "interreflection solve",
                done: channel,
                total: self.channels,
            });
            let solution = solve(ff, &self.reflectance[channel], &block, &solve_options)?;
            indirect_by_channel.push(solution.irradiance);
            reports.push(solution.columns);
        }
        progress(Progress {
            stage: "interreflection solve",
            done: self.channels,
            total: self.channels,
        });
        timings.solve_s = t.elapsed().as_secs_f64();

        let mut offset = 0;
        let mut baked = Vec::with_capacity(lights.len());
        for ((light, direct), &k) in lights.iter().zip(&directs).zip(&widths) {
            let columns = offset..offset + k;
            let indirect = indirect_by_channel
                .iter()
                .map(|h| {
                    let mut out = vec![0f32; n * k];
                    for p in 0..n {
                        for c in 0..k {
                            out[p * k + c] = (h.get(p, offset + c) - direct[p * k + c]) as f32;
                        }
                    }
                    out
                })
                .collect();
            let column_reports = reports.iter().flat_map(|r| &r[columns.clone()]);
            let (iterations, certified_error) = column_reports.fold((0, 0.0f64), |(it, err), c| {
                let rel = if c.radiosity_norm > 0.0 {
                    c.error_bound / c.radiosity_norm
                } else {
                    0.0
                };
                (it.max(c.iterations), err.max(rel))
            });
            baked.push(BakedLight {
                plan: light.plan.clone(),
                n_columns: k,
                direct: direct.iter().map(|&v| v as f32).collect(),
                indirect,
                iterations,
                certified_error,
                from_cache: false,
            });
            offset += k;
        }
        Ok(baked)
    }
}

impl BakedLight {
    /// A light with no stored basis (a room that reflects nothing, or a light whose bake is
    /// still to come).
    pub fn without_indirect(plan: &LightPlan) -> Self {
        BakedLight {
            plan: plan.clone(),
            n_columns: plan.columns,
            direct: Vec::new(),
            indirect: Vec::new(),
            iterations: 0,
            certified_error: 0.0,
            from_cache: false,
        }
    }
}

/// Hash of the room part of every light's cache key: the format version, the coarse mesh,
/// reflectances, occluders, the plan's effects and the solver settings.
fn room_key(scene: &Scene, transport: &Transport) -> u64 {
    let mut h = Fnv64::default();
    h.u64(u64::from(cache::FORMAT_VERSION)).str("haiko-bake");
    let mesh = &scene.coarse;
    h.u64(mesh.positions.len() as u64);
    for p in &mesh.positions {
        h.f64(p.x).f64(p.y).f64(p.z);
    }
    for patch in &mesh.patches {
        for &v in patch.vertex_ids() {
            h.u64(u64::from(v));
        }
        h.u64(u64::from(patch.surface));
    }
    for s in &scene.surfaces {
        h.str(&s.name);
        for c in s.reflectance.0 {
            h.f64(c);
        }
    }
    hash_occluders(scene, &mut h);
    h.u64(u64::from(transport.visibility))
        .u64(u64::from(transport.interreflection))
        .u64(transport.channels as u64);
    let ff = &transport.form_factor_options;
    h.f64(transport.tolerance)
        .f64(ff.near_field_ratio)
        .u64(ff.visibility_samples_per_edge as u64);
    h.finish()
}

fn encode(w: &mut impl ValueSink, light: &BakedLight) {
    w.u64(light.n_columns as u64);
    w.u64(light.iterations as u64);
    w.f64s(&[light.certified_error]);
    w.f32s(&light.direct);
    w.u64(light.indirect.len() as u64);
    for channel in &light.indirect {
        w.f32s(channel);
    }
}

fn decode(r: &mut impl ValueSource, plan: &LightPlan, n_patches: usize) -> Option<BakedLight> {
    let n_columns = usize::try_from(r.u64()?).ok()?;
    let iterations = usize::try_from(r.u64()?).ok()?;
    let certified_error = *r.f64s()?.first()?;
    let direct = r.f32s()?;
    let channels = usize::try_from(r.u64()?).ok()?;
    let indirect: Vec<Vec<f32>> = (0..channels.min(3)).map(|_| r.f32s()).collect::<Option<_>>()?;
    let sized = |v: &Vec<f32>| v.is_empty() || v.len() == n_patches * n_columns;
    (n_columns == plan.columns && sized(&direct) && indirect.iter().all(sized)).then(|| BakedLight {
        plan: plan.clone(),
        n_columns,
        direct,
        indirect,
        iterations,
        certified_error,
        from_cache: true,
    })
}

/// Plans `scene` and bakes every light (or loads it from the cache), reporting progress.
///
/// Errors: the interreflection solve failing (internal).
pub fn bake(scene: &Scene, options: &BakeOptions, progress: &mut dyn FnMut(Progress)) -> Result<Bake> {
    let t = Instant::now();
    let plan = plan(scene, options.plan);
    let plan_s = t.elapsed().as_secs_f64();
    let mut baked = bake_planned(scene, plan, options, progress)?;
    baked.timings.plan_s = plan_s;
    Ok(baked)
}

/// Bakes every light of `scene` (or loads it from the cache) as `plan` (made by
/// [`crate::transport::plan::plan`] for this scene and `options.plan`) says; `timings.plan_s`
/// is left 0.
///
/// Errors: the interreflection solve failing (internal).
pub fn bake_planned(
    scene: &Scene,
    plan: Plan,
    options: &BakeOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Bake> {
    let transport = Arc::new(Transport::new(
        scene,
        &plan,
        options,
        Occluders::of_scene(scene).map(Arc::new),
    ));
    let specs: Vec<LightBakeSpec> = scene
        .lights
        .iter()
        .zip(&plan.lights)
        .map(|(light, lp)| LightBakeSpec::new(light, lp))
        .collect();
    let (lights, report) = transport.bake_lights(&specs, options.cache.as_ref(), progress)?;
    let (form_factor_rays, form_factor_bytes) = transport.form_factor_stats();
    Ok(Bake {
        plan,
        transport,
        lights,
        timings: report.timings,
        notices: report.notices,
        form_factor_rays,
        form_factor_bytes,
    })
}

/// Sets up the transport of `scene` under `plan` without baking any basis: every light gets
/// [`BakedLight::without_indirect`] (the hierarchical engine carries the indirect light,
/// [`crate::transport::indirect`]); `plan_s` is the time the plan took.
pub fn plan_without_basis(scene: &Scene, plan: Plan, plan_s: f64, options: &BakeOptions) -> Bake {
    let transport = Arc::new(Transport::new(
        scene,
        &plan,
        options,
        Occluders::of_scene(scene).map(Arc::new),
    ));
    let lights = plan.lights.iter().map(BakedLight::without_indirect).collect();
    Bake {
        plan,
        transport,
        lights,
        timings: BakeTimings {
            plan_s,
            ..BakeTimings::default()
        },
        notices: Vec::new(),
        form_factor_rays: 0,
        form_factor_bytes: 0,
    }
}
