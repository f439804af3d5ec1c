//! The bake (docs/METHOD.md §5, §7): per light, the indirect irradiance of every SH basis emitter on the
//! coarse patches, with interreflection solved to a certified tolerance, cached on disk per light.
//!
//! For light `i` with order N the basis has `K = (N + 1)²` emitters; column `k = sh_index(l, m)`
//! is the room's response to a point source of intensity `Y_lm(ω)` at the light (masked to the
//! mounting half-space when the plan says so). Stored per column and coarse patch (f32):
//! the patch-averaged direct irradiance `E_k` and the indirect irradiance `H_k − E_k` per channel
//! (lx per unit coefficient). Relighting blends them with `c_k = w_l 4π/(2l+1) Y_lm(aim)`.

use std::path::PathBuf;
use std::time::Instant;

use glam::DVec3;

use crate::error::{Error, Result};
use crate::scene::{PatchMesh, Scene, SurfaceKind};
use crate::transport::basis::{Emitter, basis_direct};
use crate::transport::cache::{self, CacheLoad, Fnv64, PayloadReader, PayloadWriter};
use crate::transport::formfactor::{FormFactorOptions, FormFactors};
use crate::transport::occlusion::Occluders;
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
    /// Cache directory; `None` bakes without reading or writing a cache.
    pub cache_dir: Option<PathBuf>,
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

/// The emitter of light `i` under its plan.
fn emitter(scene: &Scene, plan: &LightPlan, i: usize) -> Emitter {
    let light = &scene.lights[i];
    Emitter {
        position: light.position,
        radius_m: light.radius,
        order: plan.order,
        mask: plan.mask.map(DVec3::from),
    }
}

/// The cache key of light `i`: everything its baked columns depend on.
pub fn light_key(scene: &Scene, plan: &Plan, i: usize, tolerance: f64, ff: &FormFactorOptions) -> u64 {
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
    for b in &scene.boxes {
        h.f64(b.min.x)
            .f64(b.min.y)
            .f64(b.min.z)
            .f64(b.max.x)
            .f64(b.max.y)
            .f64(b.max.z);
    }
    // OBJ occluders are the fine triangles of mesh surfaces.
    for ([a, b, c], pid) in scene.fine.triangles() {
        let surface = scene.fine.patches[pid as usize].surface as usize;
        if matches!(scene.surfaces[surface].kind, SurfaceKind::Mesh { .. }) {
            for v in [a, b, c] {
                let p = scene.fine.positions[v as usize];
                h.f64(p.x).f64(p.y).f64(p.z);
            }
        }
    }
    let lp = &plan.lights[i];
    let light = &scene.lights[i];
    h.f64(light.position.x)
        .f64(light.position.y)
        .f64(light.position.z)
        .f64(light.radius);
    h.u64(lp.order as u64);
    match lp.mask {
        Some(n) => h.u64(1).f64(n[0]).f64(n[1]).f64(n[2]),
        None => h.u64(0),
    };
    h.u64(u64::from(plan.visibility.on))
        .u64(u64::from(plan.interreflection.on))
        .u64(plan.channels as u64);
    h.f64(tolerance)
        .f64(ff.near_field_ratio)
        .u64(ff.visibility_samples_per_edge as u64);
    h.finish()
}

fn encode(light: &BakedLight) -> Vec<u8> {
    let mut w = PayloadWriter::default();
    w.u64(light.n_columns as u64);
    w.u64(light.iterations as u64);
    w.f64s(&[light.certified_error]);
    w.f32s(&light.direct);
    w.u64(light.indirect.len() as u64);
    for channel in &light.indirect {
        w.f32s(channel);
    }
    w.0
}

fn decode(payload: &[u8], plan: &LightPlan, n_patches: usize) -> Option<BakedLight> {
    let mut r = PayloadReader::new(payload);
    let n_columns = usize::try_from(r.u64()?).ok()?;
    let iterations = usize::try_from(r.u64()?).ok()?;
    let certified_error = *r.f64s()?.first()?;
    let direct = r.f32s()?;
    let channels = usize::try_from(r.u64()?).ok()?;
    let indirect: Vec<Vec<f32>> = (0..channels.min(3)).map(|_| r.f32s()).collect::<Option<_>>()?;
    let sized = |v: &Vec<f32>| v.is_empty() || v.len() == n_patches * n_columns;
    (r.is_done() && n_columns == plan.columns && sized(&direct) && indirect.iter().all(sized)).then(|| {
        BakedLight {
            plan: plan.clone(),
            n_columns,
            direct,
            indirect,
            iterations,
            certified_error,
            from_cache: true,
        }
    })
}

/// Bakes `scene` (or loads it from the cache), reporting progress.
pub fn bake(scene: &Scene, options: &BakeOptions, progress: &mut dyn FnMut(Progress)) -> Result<Bake> {
    let t = Instant::now();
    let plan = plan(scene, options.plan);
    let mut timings = BakeTimings {
        plan_s: t.elapsed().as_secs_f64(),
        ..BakeTimings::default()
    };
    let tolerance = options.tolerance.unwrap_or(scene.settings.tolerance);
    let ff_options = options.form_factors.unwrap_or_else(default_form_factor_options);
    let n = scene.coarse.patches.len();
    let mut notices = Vec::new();

    // 1. The cache.
    let t = Instant::now();
    let keys: Vec<u64> = (0..scene.lights.len())
        .map(|i| light_key(scene, &plan, i, tolerance, &ff_options))
        .collect();
    let mut lights: Vec<Option<BakedLight>> = vec![None; scene.lights.len()];
    if let Some(dir) = &options.cache_dir {
        for (i, &key) in keys.iter().enumerate() {
            let path = cache::file_for(dir, key);
            match cache::read(&path, key) {
                CacheLoad::Hit(payload) => match decode(&payload, &plan.lights[i], n) {
                    Some(light) => lights[i] = Some(light),
                    None => notices.push(format!("{}: unreadable bake payload, rebuilding", path.display())),
                },
                CacheLoad::Missing => {}
                CacheLoad::Invalid(why) => notices.push(format!("cache {why}; rebuilding")),
            }
        }
    }
    timings.cache_read_s = t.elapsed().as_secs_f64();
    let todo: Vec<usize> = (0..scene.lights.len()).filter(|&i| lights[i].is_none()).collect();

    // 2. Nothing reflects: no columns at all.
    let mut form_factor_rays = 0;
    let mut form_factor_bytes = 0;
    if !plan.interreflection.on {
        for &i in &todo {
            lights[i] = Some(BakedLight {
                plan: plan.lights[i].clone(),
                n_columns: plan.lights[i].columns,
                direct: Vec::new(),
                indirect: Vec::new(),
                iterations: 0,
                certified_error: 0.0,
                from_cache: false,
            });
        }
    } else if !todo.is_empty() {
        // 3. Form factors and the basis direct irradiance (visibility only where planned).
        let occluders = plan
            .visibility
            .on
            .then(|| Occluders::of_scene(scene).unwrap_or_else(|| Occluders::from_parts(&[], &[])));
        progress(Progress {
            stage: "form factors",
            done: 0,
            total: n,
        });
        let t = Instant::now();
        let mut ff = match &occluders {
            Some(occ) => FormFactors::build(&scene.coarse, occ, ff_options),
            None => FormFactors::build(&scene.coarse, &Unoccluded, ff_options),
        };
        let areas: Vec<f64> = scene.coarse.patches.iter().map(|p| p.area).collect();
        ff.balance(&areas);
        timings.form_factors_s = t.elapsed().as_secs_f64();
        form_factor_rays = ff.rays_cast();
        form_factor_bytes = ff.bytes();
        progress(Progress {
            stage: "form factors",
            done: n,
            total: n,
        });

        let t = Instant::now();
        let vis = occluders.as_ref().map(|o| o as &dyn Visibility);
        let mut directs = Vec::with_capacity(todo.len());
        for (done, &i) in todo.iter().enumerate() {
            progress(Progress {
                stage: "basis direct light",
                done,
                total: todo.len(),
            });
            directs.push(basis_direct(
                &scene.coarse,
                &emitter(scene, &plan.lights[i], i),
                vis,
            ));
        }
        progress(Progress {
            stage: "basis direct light",
            done: todo.len(),
            total: todo.len(),
        });
        timings.basis_direct_s = t.elapsed().as_secs_f64();

        // 4. One block solve over all columns of all lights to bake, per channel.
        let t = Instant::now();
        let widths: Vec<usize> = todo.iter().map(|&i| plan.lights[i].columns).collect();
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
            tolerance,
            ..SolveOptions::default()
        };
        let mut indirect_by_channel = Vec::with_capacity(plan.channels);
        let mut reports = Vec::new();
        for channel in 0..plan.channels {
            progress(Progress {
                stage: "interreflection solve",
                done: channel,
                total: plan.channels,
            });
            let rho = patch_reflectance(scene, &scene.coarse, channel);
            let solution = solve(&ff, &rho, &block, &solve_options)?;
            indirect_by_channel.push(solution.irradiance);
            reports.push(solution.columns);
        }
        progress(Progress {
            stage: "interreflection solve",
            done: plan.channels,
            total: plan.channels,
        });
        timings.solve_s = t.elapsed().as_secs_f64();

        let mut offset = 0;
        for ((&i, direct), &k) in todo.iter().zip(&directs).zip(&widths) {
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
            lights[i] = Some(BakedLight {
                plan: plan.lights[i].clone(),
                n_columns: k,
                direct: direct.iter().map(|&v| v as f32).collect(),
                indirect,
                iterations,
                certified_error,
                from_cache: false,
            });
            offset += k;
        }
    }

    // 5. Write what was baked.
    let t = Instant::now();
    if let Some(dir) = &options.cache_dir {
        for &i in &todo {
            let light = lights[i].as_ref().expect("every light to bake was baked");
            if let Err(e) = cache::write_atomic(&cache::file_for(dir, keys[i]), keys[i], &encode(light)) {
                notices.push(format!(
                    "could not write the bake cache in {}: {e}",
                    dir.display()
                ));
            }
        }
    }
    timings.cache_write_s = t.elapsed().as_secs_f64();
    let lights = lights
        .into_iter()
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| Error::internal("a light was not baked"))?;
    Ok(Bake {
        plan,
        lights,
        timings,
        notices,
        form_factor_rays,
        form_factor_bytes,
    })
}
