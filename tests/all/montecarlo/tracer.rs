//! An independent Monte-Carlo reference for total illuminance: a small path tracer with its own
//! ray–scene intersection (the room's box interior, axis-aligned boxes, OBJ triangles in its own
//! BVH), its own curve interpolation and the same light model as Haiko's exact direct light
//! (`E = I(γ) cosθ / (r² + a²) · V`, docs/METHOD.md §5). Only the room file is shared with the
//! code under test (through the loader); no transport code of the crate is used.
//!
//! Estimator at a receiver `p` with normal `n`: the direct part is evaluated exactly (next-event
//! estimation against every point light, with a shadow ray), the indirect part
//! `E_ind(p) = ∫ L cosθ dω` by cosine-weighted hemisphere sampling: a path `p → x₁ → x₂ → …`
//! contributes `Σ_k (Π_{j<k} ρ_j) · (M + ρ_k E_dir(x_k))` per channel (`M` a uniform self-emission
//! of every surface, zero except in the furnace test). The term `ρ_k E_dir(x_k)` — light reflected
//! once from where the lights land — is also sampled from the lights' emission at every vertex and
//! the two estimates are combined by multiple importance sampling (balance heuristic), so hot
//! spots beside lamps and spot pools converge. Paths end by Russian roulette with the survival
//! probability `max ρ` of the surface hit (unbiased), or at a black surface. The first direction of
//! each batch of `m²` paths is stratified on an `m × m` grid; the standard error is the spread of
//! the batch means.

use glam::DVec3;
use haiko::scene::{Scene, SurfaceKind};

/// Rec. 709 luminance weights: lux of a linear-RGB irradiance.
const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Relative distance kept from both ends of a shadow ray (so points on surfaces see the light).
const SHADOW_END: f64 = 1e-9;
/// Distance (m) a path vertex is lifted off its surface before the next ray.
const LIFT_M: f64 = 1e-9;

/// Photopic lux of a linear-RGB irradiance.
pub fn lux(rgb: [f64; 3]) -> f64 {
    LUMINANCE[0] * rgb[0] + LUMINANCE[1] * rgb[1] + LUMINANCE[2] * rgb[2]
}

/// xoshiro256** seeded through SplitMix64: reproducible uniform numbers in [0, 1).
#[derive(Debug, Clone)]
pub struct Rng([u64; 4]);

impl Rng {
    /// A generator for `seed` (any value, including 0).
    pub fn new(seed: u64) -> Self {
        let mut s = seed;
        let mut next = || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        Rng([next(), next(), next(), next()])
    }

    fn next_u64(&mut self) -> u64 {
        let s = &mut self.0;
        let result = s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// A point light as the reference sees it: position, unit aim, luminous radius, the curve's
/// control points (γ in degrees, cd), dimmer and colour.
#[derive(Debug, Clone)]
pub struct RefLight {
    pub position: DVec3,
    pub aim: DVec3,
    pub radius: f64,
    pub gamma_deg: Vec<f64>,
    pub candela: Vec<f64>,
    pub dimmer: f64,
    pub color: [f64; 3],
}

impl RefLight {
    /// How the light meets the point `x` with unit normal `n`: the squared distance (m²), the
    /// cosine of incidence and the angle γ from the aim (radians); `None` at the light's centre
    /// or from behind the surface.
    fn incidence(&self, x: DVec3, n: DVec3) -> Option<(f64, f64, f64)> {
        let to = x - self.position;
        let r2 = to.length_squared();
        if r2 < 1e-12 {
            return None;
        }
        let dir = to / r2.sqrt();
        let cos_incidence = -n.dot(dir);
        (cos_incidence > 0.0).then(|| (r2, cos_incidence, self.aim.dot(dir).clamp(-1.0, 1.0).acos()))
    }

    /// Intensity (cd, dimmer applied) at angle `gamma_deg` from the aim: linear between control
    /// points, 0 outside their span, the first value at a step (two points at one angle).
    pub fn intensity(&self, gamma_deg: f64) -> f64 {
        let g = &self.gamma_deg;
        let n = g.len();
        if gamma_deg < g[0] || gamma_deg > g[n - 1] {
            return 0.0;
        }
        let mut k = 0;
        while k + 1 < n && g[k + 1] < gamma_deg {
            k += 1;
        }
        // Now g[k] ≤ γ ≤ g[k+1] (or γ = g[0]); at γ = g[k] exactly the value is candela[k].
        let value = if gamma_deg <= g[k] || k + 1 == n {
            self.candela[k]
        } else {
            let t = (gamma_deg - g[k]) / (g[k + 1] - g[k]);
            self.candela[k] + t * (self.candela[k + 1] - self.candela[k])
        };
        self.dimmer * value
    }
}

/// Samples emission directions of a light with a density close to its intensity: `BINS` bins
/// uniform in γ carry the flux of the curve in them; inside a bin, `cos γ` is uniform. The
/// density per steradian is constant per bin ([`EmissionSampler::pdf`]), which is all the
/// estimator needs (it never assumes the density is exactly `I/Φ`).
#[derive(Debug, Clone)]
pub struct EmissionSampler {
    /// Cumulative flux (lm) at the end of each bin.
    cdf: Vec<f64>,
    /// Total flux (lm, dimmer applied) of the bins.
    pub flux: f64,
}

const BINS: usize = 4096;

impl EmissionSampler {
    fn new(light: &RefLight) -> Self {
        let width = std::f64::consts::PI / BINS as f64;
        let mut cdf = Vec::with_capacity(BINS);
        let mut total = 0.0;
        for b in 0..BINS {
            // Midpoint rule on 8 sub-intervals (the bins only have to carry positive mass where
            // the curve does; the density is whatever they define).
            let mut m = 0.0;
            for k in 0..8 {
                let g = (b as f64 + (k as f64 + 0.5) / 8.0) * width;
                m += light.intensity(g.to_degrees()) * g.sin();
            }
            total += 2.0 * std::f64::consts::PI * m * width / 8.0;
            cdf.push(total);
        }
        EmissionSampler { cdf, flux: total }
    }

    fn bin_edges(b: usize) -> (f64, f64) {
        let width = std::f64::consts::PI / BINS as f64;
        (b as f64 * width, (b + 1) as f64 * width)
    }

    /// Density (1/sr) of the sampled direction at angle `gamma` (radians) from the aim.
    pub fn pdf(&self, gamma: f64) -> f64 {
        if self.flux <= 0.0 {
            return 0.0;
        }
        let b = ((gamma / std::f64::consts::PI * BINS as f64) as usize).min(BINS - 1);
        let mass = self.cdf[b] - if b == 0 { 0.0 } else { self.cdf[b - 1] };
        let (g0, g1) = Self::bin_edges(b);
        mass / (self.flux * 2.0 * std::f64::consts::PI * (g0.cos() - g1.cos()))
    }

    /// A unit direction (in the light's frame: z along the aim) from three uniform numbers.
    fn sample(&self, u: f64, v: f64, w: f64) -> DVec3 {
        let target = u * self.flux;
        let b = self.cdf.partition_point(|&c| c <= target).min(BINS - 1);
        let (g0, g1) = Self::bin_edges(b);
        let cos = g0.cos() + v * (g1.cos() - g0.cos());
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * std::f64::consts::PI * w;
        DVec3::new(sin * phi.cos(), sin * phi.sin(), cos)
    }
}

/// A triangle with its unit normal (front side) and reflectance.
#[derive(Debug, Clone, Copy)]
struct Triangle {
    v: [DVec3; 3],
    normal: DVec3,
    rho: [f64; 3],
}

/// A node of the triangle BVH: bounds, and either two children or a range of triangles.
#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Children (node indices) when `count == 0`.
    children: [usize; 2],
    /// First triangle and number of triangles of a leaf.
    first: usize,
    count: usize,
}

/// A median-split BVH over triangles.
/// Margin (m) around a BVH node's triangles.
const NODE_PAD_M: f64 = 1e-9;

#[derive(Debug, Clone, Default)]
struct Bvh {
    nodes: Vec<Node>,
    triangles: Vec<Triangle>,
}

impl Bvh {
    fn new(mut triangles: Vec<Triangle>) -> Self {
        let mut nodes = Vec::new();
        if !triangles.is_empty() {
            let n = triangles.len();
            Self::build(&mut triangles, 0, n, &mut nodes);
        }
        Bvh { nodes, triangles }
    }

    /// Builds the subtree of `tris[start..end]` and returns its root's index (the root of the
    /// whole tree is node 0).
    fn build(tris: &mut [Triangle], start: usize, end: usize, nodes: &mut Vec<Node>) -> usize {
        let (lo, hi) = tris[start..end]
            .iter()
            .flat_map(|t| t.v)
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p), hi.max(p))
            });
        // Padded: a node holding only an axis-aligned face is flat, and the strict slab test
        // would let every ray through it.
        let pad = DVec3::splat(NODE_PAD_M);
        let index = nodes.len();
        nodes.push(Node {
            lo: lo - pad,
            hi: hi + pad,
            children: [0, 0],
            first: start,
            count: end - start,
        });
        if end - start > 4 {
            let axis = (hi - lo).max_position();
            let centroid = |t: &Triangle| t.v[0][axis] + t.v[1][axis] + t.v[2][axis];
            tris[start..end].sort_by(|a, b| centroid(a).total_cmp(&centroid(b)));
            let mid = (start + end) / 2;
            let left = Self::build(tris, start, mid, nodes);
            let right = Self::build(tris, mid, end, nodes);
            nodes[index].children = [left, right];
            nodes[index].count = 0;
        }
        index
    }

    /// Nearest hit `(t, triangle)` of `o + t d` with `t_min < t < t_max`.
    fn nearest(&self, o: DVec3, d: DVec3, t_min: f64, mut t_max: f64) -> Option<(f64, usize)> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = d.recip();
        let mut best = None;
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = self.nodes[i];
            if !slab_overlap(node.lo, node.hi, o, inv, t_min, t_max) {
                continue;
            }
            if node.count == 0 {
                stack.extend(node.children);
                continue;
            }
            for k in node.first..node.first + node.count {
                if let Some(t) = hit_triangle(&self.triangles[k], o, d)
                    && t > t_min
                    && t < t_max
                {
                    t_max = t;
                    best = Some((t, k));
                }
            }
        }
        best
    }
}

/// Möller–Trumbore: the ray parameter of the hit with the triangle's plane inside it.
fn hit_triangle(tri: &Triangle, o: DVec3, d: DVec3) -> Option<f64> {
    let (e1, e2) = (tri.v[1] - tri.v[0], tri.v[2] - tri.v[0]);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return None;
    }
    let s = o - tri.v[0];
    let u = s.dot(p) / det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some(e2.dot(q) / det)
}

/// True when the ray `o + t d`, `t_min < t < t_max`, passes through the box `[lo, hi]`.
fn slab_overlap(lo: DVec3, hi: DVec3, o: DVec3, inv: DVec3, t_min: f64, t_max: f64) -> bool {
    let (enter, exit) = slab(lo, hi, o, inv);
    enter.max(t_min) < exit.min(t_max)
}

/// Entry and exit parameters of a ray through an axis-aligned box (NaN components, from a ray in
/// a slab's plane, are dropped by `max`/`min`).
fn slab(lo: DVec3, hi: DVec3, o: DVec3, inv: DVec3) -> (f64, f64) {
    let ta = (lo - o) * inv;
    let tb = (hi - o) * inv;
    let near = ta.min(tb);
    let far = ta.max(tb);
    (near.max_element(), far.min_element())
}

/// What a ray hit: where, the surface normal facing the ray, and the reflectance (None for the
/// back of an OBJ triangle, which neither reflects nor emits).
struct Hit {
    point: DVec3,
    normal: DVec3,
    rho: Option<[f64; 3]>,
}

/// The scene as the reference tracer sees it.
#[derive(Debug, Clone)]
pub struct Tracer {
    size: DVec3,
    /// Reflectance of floor, ceiling, wall x = 0, wall x = max, wall y = 0, wall y = max.
    room_rho: [[f64; 3]; 6],
    boxes: Vec<(DVec3, DVec3, [f64; 3])>,
    triangles: Bvh,
    lights: Vec<RefLight>,
    /// Per light, its emission sampler.
    samplers: Vec<EmissionSampler>,
    /// Uniform self-emission (lm/m², per channel) of every surface: the furnace test's source.
    emission: [f64; 3],
}

impl Tracer {
    /// The room, boxes, OBJ triangles and lights of a loaded scene.
    pub fn new(scene: &Scene) -> Self {
        let rho_of = |kind: &dyn Fn(&SurfaceKind) -> bool| {
            scene
                .surfaces
                .iter()
                .find(|s| kind(&s.kind))
                .map_or([0.0; 3], |s| s.reflectance.0)
        };
        let wall = |name: &str| {
            scene
                .surfaces
                .iter()
                .find(|s| s.name == name)
                .map_or([0.0; 3], |s| s.reflectance.0)
        };
        let room_rho = [
            rho_of(&|k| matches!(k, SurfaceKind::Floor)),
            rho_of(&|k| matches!(k, SurfaceKind::Ceiling)),
            wall("wall-x0"),
            wall("wall-x1"),
            wall("wall-y0"),
            wall("wall-y1"),
        ];
        let boxes = scene
            .boxes
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let rho = rho_of(&|k| matches!(k, SurfaceKind::BoxFace { box_index } if *box_index == i));
                (b.min, b.max, rho)
            })
            .collect();
        let mut triangles = Vec::new();
        for ([a, b, c], pid) in scene.fine.triangles() {
            let patch = &scene.fine.patches[pid as usize];
            let surface = &scene.surfaces[patch.surface as usize];
            if matches!(surface.kind, SurfaceKind::Mesh { .. }) {
                let v = [a, b, c].map(|i| scene.fine.positions[i as usize]);
                let normal = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                triangles.push(Triangle {
                    v,
                    normal,
                    rho: surface.reflectance.0,
                });
            }
        }
        let lights: Vec<RefLight> = scene
            .lights
            .iter()
            .map(|l| RefLight {
                position: l.position,
                aim: l.aim.normalize(),
                radius: l.radius,
                gamma_deg: l.curve.gammas_deg().to_vec(),
                candela: l.curve.intensities_cd().to_vec(),
                dimmer: l.dimmer,
                color: l.color,
            })
            .collect();
        let samplers = lights.iter().map(EmissionSampler::new).collect();
        Tracer {
            size: scene.room_size,
            room_rho,
            boxes,
            triangles: Bvh::new(triangles),
            lights,
            samplers,
            emission: [0.0; 3],
        }
    }

    /// Replaces the lights by a uniform self-emission `M` (lm/m², per channel) of every surface:
    /// the furnace test.
    pub fn emit_uniformly(&mut self, m: [f64; 3]) {
        self.lights.clear();
        self.samplers.clear();
        self.emission = m;
    }

    /// True when nothing blocks the open segment `a → b` (the room's walls never do).
    fn unblocked(&self, a: DVec3, b: DVec3) -> bool {
        let d = b - a;
        let inv = d.recip();
        let (t0, t1) = (SHADOW_END, 1.0 - SHADOW_END);
        if self
            .boxes
            .iter()
            .any(|&(lo, hi, _)| slab_overlap(lo, hi, a, inv, t0, t1))
        {
            return false;
        }
        self.triangles.nearest(a, d, t0, t1).is_none()
    }

    /// Exact direct irradiance (lx, linear RGB) at `x` with unit normal `n` from every light.
    pub fn direct(&self, x: DVec3, n: DVec3) -> [f64; 3] {
        let mut e = [0.0; 3];
        for light in &self.lights {
            let Some((r2, cos_incidence, gamma)) = light.incidence(x, n) else {
                continue;
            };
            let intensity = light.intensity(gamma.to_degrees());
            if intensity == 0.0 || !self.unblocked(light.position, x) {
                continue;
            }
            let value = intensity * cos_incidence / (r2 + light.radius * light.radius);
            for ch in 0..3 {
                e[ch] += light.color[ch] * value;
            }
        }
        e
    }

    /// The nearest surface along the ray from `o` (inside the room) in unit direction `d`.
    fn trace(&self, o: DVec3, d: DVec3) -> Hit {
        // The room: the ray leaves through the first wall it meets.
        let mut t_best = f64::INFINITY;
        let mut face = 0;
        for axis in 0..3 {
            let (t, f) = if d[axis] > 0.0 {
                ((self.size[axis] - o[axis]) / d[axis], [3, 5, 1][axis])
            } else if d[axis] < 0.0 {
                (-o[axis] / d[axis], [2, 4, 0][axis])
            } else {
                continue;
            };
            if t < t_best {
                t_best = t;
                face = f;
            }
        }
        // face: 0 floor, 1 ceiling, 2 x0, 3 x1, 4 y0, 5 y1 (see `room_rho`).
        let room_normal = [
            DVec3::Z,
            DVec3::NEG_Z,
            DVec3::X,
            DVec3::NEG_X,
            DVec3::Y,
            DVec3::NEG_Y,
        ];
        let mut hit = Hit {
            point: o + d * t_best,
            normal: room_normal[face],
            rho: Some(self.room_rho[face]),
        };
        let inv = d.recip();
        for &(lo, hi, rho) in &self.boxes {
            let ta = (lo - o) * inv;
            let tb = (hi - o) * inv;
            let near = ta.min(tb);
            let far = ta.max(tb);
            let enter = near.max_element();
            let exit = far.min_element();
            if enter > 0.0 && enter < exit && enter < t_best {
                t_best = enter;
                let axis = if near.x >= near.y && near.x >= near.z {
                    0
                } else if near.y >= near.z {
                    1
                } else {
                    2
                };
                let mut normal = DVec3::ZERO;
                normal[axis] = -d[axis].signum();
                hit = Hit {
                    point: o + d * enter,
                    normal,
                    rho: Some(rho),
                };
            }
        }
        if let Some((t, k)) = self.triangles.nearest(o, d, 0.0, t_best) {
            let tri = &self.triangles.triangles[k];
            let front = tri.normal.dot(d) < 0.0;
            hit = Hit {
                point: o + d * t,
                normal: if front { tri.normal } else { -tri.normal },
                rho: front.then_some(tri.rho),
            };
        }
        hit
    }

    /// Exact direct irradiance (lx, linear RGB) at `x` (normal `n`) and the area density (1/m²)
    /// with which [`Self::light_sample`] produces `x`: `Σ_L P(L) p_L(ω) cosθ / r² · V`.
    fn direct_with_density(&self, x: DVec3, n: DVec3) -> ([f64; 3], f64) {
        let mut e = [0.0; 3];
        let mut density = 0.0;
        let total: f64 = self.samplers.iter().map(|s| s.flux).sum();
        for (light, sampler) in self.lights.iter().zip(&self.samplers) {
            let Some((r2, cos_incidence, gamma)) = light.incidence(x, n) else {
                continue;
            };
            let intensity = light.intensity(gamma.to_degrees());
            let pdf = sampler.pdf(gamma);
            if (intensity == 0.0 && pdf == 0.0) || !self.unblocked(light.position, x) {
                continue;
            }
            let value = intensity * cos_incidence / (r2 + light.radius * light.radius);
            for ch in 0..3 {
                e[ch] += light.color[ch] * value;
            }
            if total > 0.0 {
                density += sampler.flux / total * pdf * cos_incidence / r2;
            }
        }
        (e, density)
    }

    /// The first-bounce light reflected towards `y` (normal `n`) from a point `x` where a light
    /// sends its light: pick a light by flux, a direction by its sampler, `x` the first surface
    /// hit. Balance-heuristic weight against cosine sampling (see [`Self::path`]); per channel.
    fn light_sample(&self, y: DVec3, n: DVec3, rng: &mut Rng) -> [f64; 3] {
        let total: f64 = self.samplers.iter().map(|s| s.flux).sum();
        if total <= 0.0 {
            return [0.0; 3];
        }
        let mut pick = rng.uniform() * total;
        let mut chosen = self.samplers.len() - 1;
        for (i, s) in self.samplers.iter().enumerate() {
            if pick < s.flux {
                chosen = i;
                break;
            }
            pick -= s.flux;
        }
        let light = &self.lights[chosen];
        let local = self.samplers[chosen].sample(rng.uniform(), rng.uniform(), rng.uniform());
        let (t, b) = light.aim.any_orthonormal_pair();
        let dir = (t * local.x + b * local.y + light.aim * local.z).normalize();
        let hit = self.trace(light.position, dir);
        let Some(rho) = hit.rho else { return [0.0; 3] };
        let x = hit.point;
        let d = x - y;
        let d2 = d.length_squared();
        let dist = d2.sqrt();
        let (cos_y, cos_x) = (n.dot(d) / dist, -hit.normal.dot(d) / dist);
        if cos_y <= 0.0 || cos_x <= 0.0 || !self.unblocked(y, x) {
            return [0.0; 3];
        }
        let (e_dir, p_light) = self.direct_with_density(x, hit.normal);
        let p_cosine = cos_y * cos_x / (std::f64::consts::PI * d2);
        if p_light <= 0.0 {
            return [0.0; 3];
        }
        // f / (p_cosine + p_light) with f = ρ E_dir cos_y cos_x / (π d²) = ρ E_dir p_cosine.
        let w = p_cosine / (p_cosine + p_light);
        [0, 1, 2].map(|ch| rho[ch] * e_dir[ch] * w)
    }

    /// One path's indirect contribution at `p` (normal `n`) whose first direction comes from
    /// the unit square sample `(u1, u2)` (lx, linear RGB). At every vertex the light reflected
    /// once from where the lights land is estimated twice and combined with the balance
    /// heuristic (multiple importance sampling): by cosine sampling (the next surface hit) and
    /// by sampling the lights' emission ([`Self::light_sample`]); hot spots next to a lamp and
    /// the pools of spots are then sampled where they are, not found by chance.
    fn path(&self, p: DVec3, n: DVec3, u1: f64, u2: f64, rng: &mut Rng) -> [f64; 3] {
        let mut sum = [0.0; 3];
        let mut throughput = [1.0; 3];
        let mut origin = p + n * LIFT_M;
        let mut normal = n;
        let (mut a, mut b) = (u1, u2);
        loop {
            let by_light = self.light_sample(origin, normal, rng);
            for ch in 0..3 {
                sum[ch] += throughput[ch] * by_light[ch];
            }
            let d = cosine_direction(normal, a, b);
            let hit = self.trace(origin, d);
            let Some(rho) = hit.rho else { break };
            let (e_dir, p_light) = self.direct_with_density(hit.point, hit.normal);
            let to = hit.point - origin;
            let d2 = to.length_squared();
            let p_cosine = normal.dot(d) * -hit.normal.dot(d) / (std::f64::consts::PI * d2);
            let w = if p_light > 0.0 {
                p_cosine / (p_cosine + p_light)
            } else {
                1.0
            };
            for ch in 0..3 {
                sum[ch] += throughput[ch] * (self.emission[ch] + rho[ch] * e_dir[ch] * w);
            }
            // Continue with probability max ρ, weighting by ρ / max ρ (unbiased).
            let survive = rho[0].max(rho[1]).max(rho[2]);
            if survive <= 0.0 || rng.uniform() >= survive {
                break;
            }
            for ch in 0..3 {
                throughput[ch] *= rho[ch] / survive;
            }
            origin = hit.point + hit.normal * LIFT_M;
            normal = hit.normal;
            a = rng.uniform();
            b = rng.uniform();
        }
        sum
    }

    /// Photopic lux of the exact direct part at a receiver.
    pub fn direct_lux(&self, p: DVec3, n: DVec3) -> f64 {
        lux(self.direct(p, n))
    }

    /// Means (photopic lux) of the indirect part at a receiver over `batches` independent batches
    /// of `strata²` paths each, the first directions of a batch stratified on a grid.
    pub fn indirect_batches(
        &self,
        p: DVec3,
        n: DVec3,
        strata: usize,
        batches: usize,
        rng: &mut Rng,
    ) -> Vec<f64> {
        let m = strata.max(1);
        (0..batches)
            .map(|_| {
                let mut acc = [0.0; 3];
                for i in 0..m {
                    for j in 0..m {
                        let u1 = (i as f64 + rng.uniform()) / m as f64;
                        let u2 = (j as f64 + rng.uniform()) / m as f64;
                        let c = self.path(p, n, u1, u2, rng);
                        for ch in 0..3 {
                            acc[ch] += c[ch];
                        }
                    }
                }
                lux(acc) / (m * m) as f64
            })
            .collect()
    }

    /// Total illuminance at a receiver with its standard error: the exact direct part plus the
    /// indirect part from `batches` batches of `strata²` paths.
    pub fn estimate(&self, p: DVec3, n: DVec3, strata: usize, batches: usize, rng: &mut Rng) -> Estimate {
        let means = self.indirect_batches(p, n, strata, batches, rng);
        Estimate::from_batches(self.direct_lux(p, n), &means, strata * strata)
    }
}

/// A Monte-Carlo estimate: total lux, its (exact) direct part, the standard error of the total
/// and the number of paths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub total: f64,
    pub direct: f64,
    pub std_error: f64,
    pub paths: usize,
}

impl Estimate {
    /// From the exact direct part and the indirect means of independent, equal batches of
    /// `batch_paths` paths each.
    pub fn from_batches(direct: f64, means: &[f64], batch_paths: usize) -> Self {
        let k = means.len() as f64;
        let mean = means.iter().sum::<f64>() / k;
        let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (k - 1.0).max(1.0);
        Estimate {
            total: direct + mean,
            direct,
            std_error: (var / k).sqrt(),
            paths: means.len() * batch_paths,
        }
    }
}

/// A cosine-distributed unit direction around `n` from the unit square sample `(u1, u2)`.
pub fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let (t, b) = n.any_orthonormal_pair();
    let r = u1.sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    let z = (1.0 - u1).max(0.0).sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize()
}
