//! Exact direct light at every pixel of a view, kept so that an edit of one light touches only
//! that light's term (docs/DECISIONS.md, "Per-pixel direct light").
//!
//! At each visible point `p` with normal `n` (from [`PixelSurfaces`]) a light at `q` with
//! luminous radius `a` gives `E = I(γ) · cosθ / (r² + a²) · V` (the same factor as
//! [`crate::transport::direct::geometry_factor`]), γ the angle between the light's aim and
//! `p − q`, V the visibility (a shadow ray through [`Occluders`]).
//!
//! What is kept, per pixel:
//! * shared: the [`PixelSurfaces`] (point, triangle, weights) and `others`, the direct light of
//!   every light but the *active* one (lx, linear RGB, dimmer and colour applied);
//! * per light: one visibility bit (only when the scene has occluders);
//! * for the active light (the one edited last): γ (degrees), its curve coordinate
//!   ([`super::lookup`]: segment and fraction) and `cosθ / (r² + a²) · V`, 16 bytes.
//!
//! A dimmer or colour edit of the active light, or a curve edit that moves no angle, costs one
//! interpolation per pixel; a curve edit that moves an angle re-derives the coordinates from γ;
//! a re-aim re-computes γ; editing another light makes it active (re-summing `others` over the
//! lights once); moving a light casts its shadow rays again. Nothing accumulates: `others` is
//! always a fresh sum, so a room whose lights are all off is exactly 0.
//!
//! Everything but the active light's γ is computed in one parallel sweep over the pixels
//! ([`PixelLighting::sweep`]): chunk by chunk of [`shadows::chunk_pixels`], light by light, the
//! geometry in f32, the shadow rays cast again where asked ([`shadows::cast_shadow_rays`]: per
//! 16-pixel column of the chunk against only the occluders that can meet a segment from its
//! points to the light, [`Occluders::toward`]), else the light's visibility bits applied, then
//! the light added into `others` or kept as the active light's factor.
//!
//! [`PixelLighting::render_into`] adds the per-vertex indirect light (Gouraud over each pixel's
//! triangle) and shades the pixel in the same pass.

use glam::DVec3;
use rayon::prelude::*;

use super::camera::View;
use super::shade::{DisplayShader, FalseColorTable, Shader};
use super::shadows::{self, ShadowBits, ShadowChunk};
use super::surface::{NO_TRIANGLE, PixelSurfaces};
use super::tone::{self, tone_srgb8_lit};
use super::{BACKGROUND_RGB, Frame};
use crate::error::{Error, Result};
use crate::photometry::LightState;
use crate::photometry::lookup::{CurveLookup, SinHalfTable, acos};
use crate::scene::model::{PatchMesh, Surface};
use crate::transport::direct::MIN_DISTANCE_M;
use crate::transport::occlusion::Occluders;

/// Pixels per parallel task.
const PIXELS_PER_TASK: usize = 8192;

/// Pixels composed and shaded together (a scratch block of 3 KiB on the stack).
const BLOCK: usize = 256;

/// A light as the per-pixel direct light sees it: where it is and what it emits.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelLight {
    /// Position (world, m).
    pub position: DVec3,
    /// Luminous radius `a` (m): near-field softening `cosθ / (r² + a²)`.
    pub radius_m: f64,
    /// Curve, aim, dimmer and colour.
    pub state: LightState,
}

impl PixelLight {
    /// A light at `position` (world, m) with luminous radius `radius_m` emitting as `state`
    /// says, its aim scaled to unit length (kept bit for bit when already unit to rounding, so
    /// the same light built twice compares equal).
    pub fn new(position: DVec3, radius_m: f64, state: LightState) -> PixelLight {
        PixelLight {
            position,
            radius_m,
            state: LightState {
                aim: unit(state.aim),
                ..state
            },
        }
    }
}

impl From<&crate::scene::Light> for PixelLight {
    fn from(light: &crate::scene::Light) -> Self {
        PixelLight::new(light.position, light.radius, LightState::from(light))
    }
}

/// One light's entry: the light and its curve tables.
#[derive(Debug, Clone)]
struct Entry {
    light: PixelLight,
    lookup: CurveLookup,
    /// The curve in `sin(γ/2)` for the sum of the other lights, built on first need per curve.
    table: Option<SinHalfTable>,
}

impl Entry {
    fn new(light: PixelLight) -> Entry {
        Entry {
            lookup: CurveLookup::new(&light.state.curve),
            table: None,
            light,
        }
    }

    fn is_dark(&self) -> bool {
        let state = &self.light.state;
        state.dimmer == 0.0 || state.color == [0.0; 3] || state.curve.peak_cd() == 0.0
    }
}

/// Which lights' shadow rays a sweep casts again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Cast {
    /// Every light's (a new view, new lights).
    Every,
    /// One light's (it moved).
    One(usize),
    /// None: the visibility bits are kept.
    Nothing,
}

/// A light as the sweep sees it, in f32.
struct SweepLight<'a> {
    position: [f32; 3],
    /// The position in f64, where shadow rays end (world, m).
    position_m: DVec3,
    aim: [f32; 3],
    /// `a²` (m²).
    radius2: f32,
    /// Colour times dimmer.
    scale: [f32; 3],
    /// The curve, for a light added into `others` (`None`: the active light, or a dark one).
    table: Option<&'a SinHalfTable>,
    /// Whether the sweep has anything to do for this light.
    needed: bool,
    /// Whether its shadow rays are cast again.
    cast: bool,
}

impl SweepLight<'_> {
    /// Light `k` for a sweep whose active light is `active` and that casts again the shadow
    /// rays `cast` names (`None`: nothing can occlude).
    fn new(k: usize, entry: &Entry, active: Option<usize>, cast: Option<Cast>) -> SweepLight<'_> {
        let light = &entry.light;
        let [r, g, b] = light.state.color.map(|c| (c * light.state.dimmer) as f32);
        let table = (active != Some(k) && !entry.is_dark())
            .then_some(entry.table.as_ref())
            .flatten();
        let cast = cast == Some(Cast::Every) || cast == Some(Cast::One(k));
        SweepLight {
            position: light.position.as_vec3().to_array(),
            position_m: light.position,
            aim: light.state.aim.as_vec3().to_array(),
            radius2: (light.radius_m * light.radius_m) as f32,
            scale: [r, g, b],
            needed: table.is_some() || cast || active == Some(k),
            table,
            cast,
        }
    }

    /// For the pixels of `chunk`: `cosθ / (r² + a²)` (1/m², 0 where the pixel shows no
    /// surface, faces away or sits in the luminaire) into `factor` and cos γ into `cos_gamma` —
    /// the geometry of [`crate::transport::direct::geometry_factor`] in f32, one branch-free
    /// loop over the chunk's columns of coordinates (vectorised).
    fn geometry(&self, chunk: &ChunkPoints, factor: &mut [f32], cos_gamma: &mut [f32]) {
        let [qx, qy, qz] = self.position;
        let [ax, ay, az] = self.aim;
        let min_r2 = (MIN_DISTANCE_M * MIN_DISTANCE_M) as f32;
        let n = factor.len();
        let [px, py, pz] = chunk.point.each_ref().map(|c| &c[..n]);
        let [nx, ny, nz] = chunk.normal.each_ref().map(|c| &c[..n]);
        let cos_gamma = &mut cos_gamma[..n];
        for j in 0..n {
            let (dx, dy, dz) = (px[j] - qx, py[j] - qy, pz[j] - qz);
            let r2 = dx * dx + dy * dy + dz * dz;
            let inv_r = 1.0 / r2.sqrt();
            let cos_incidence = -(nx[j] * dx + ny[j] * dy + nz[j] * dz) * inv_r;
            cos_gamma[j] = (ax * dx + ay * dy + az * dz) * inv_r;
            factor[j] = if r2 >= min_r2 && cos_incidence > 0.0 {
                cos_incidence / (r2 + self.radius2)
            } else {
                0.0
            };
        }
    }

    /// Adds this light's direct light (lx, linear RGB) at the pixels whose `factor` and
    /// `cos_gamma` the sweep holds into `out`; nothing without a table.
    fn add_into(&self, factor: &[f32], cos_gamma: &[f32], out: &mut [[f32; 3]]) {
        let Some(table) = self.table else { return };
        for ((o, &f), &c) in out.iter_mut().zip(factor).zip(cos_gamma) {
            if f > 0.0 {
                let e = table.eval_cos(c) * f;
                for ch in 0..3 {
                    o[ch] += self.scale[ch] * e;
                }
            }
        }
    }
}

/// The visible points and normals of one sweep chunk's pixels, coordinate by coordinate (world,
/// m; f32); a pixel that shows no surface has the normal 0, so no light reaches it.
#[derive(Default)]
struct ChunkPoints {
    point: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
}

impl ChunkPoints {
    /// The pixels `start..start + len` of `surfaces`.
    fn new(surfaces: &PixelSurfaces, start: usize, len: usize) -> ChunkPoints {
        let mut chunk = ChunkPoints::default();
        for c in chunk.point.iter_mut().chain(chunk.normal.iter_mut()) {
            c.reserve_exact(len);
        }
        let range = start..start + len;
        let normals = surfaces.patch_normals();
        for (&t, p) in surfaces.triangle_codes()[range.clone()]
            .iter()
            .zip(&surfaces.raw_points()[range])
        {
            let n = if t == NO_TRIANGLE {
                [0.0; 3]
            } else {
                normals[(t / 2) as usize]
            };
            for axis in 0..3 {
                chunk.point[axis].push(p[axis]);
                chunk.normal[axis].push(n[axis]);
            }
        }
        chunk
    }
}

/// The active light's per-pixel cache.
#[derive(Debug, Clone, Default)]
struct Active {
    index: usize,
    /// γ per pixel (degrees).
    gamma_deg: Vec<f32>,
    /// The curve coordinate of γ per pixel: the segment ([`CurveLookup::outside`] where the
    /// light does not reach or γ is outside the curve) …
    segment: Vec<u32>,
    /// … and the fraction along it.
    fraction: Vec<f32>,
    /// `cosθ / (r² + a²) · V` per pixel (1/m²), 0 where the light cannot reach.
    factor: Vec<f32>,
}

/// Where a shading pass takes the illuminance from.
enum Source<'a> {
    /// Already composed, one value per pixel.
    Lux(&'a [[f32; 3]]),
    /// Composed on the fly, with this per-vertex indirect light.
    Compose(Option<&'a [[f32; 3]]>),
}

/// Per-pixel exact direct light of every light of a scene for one view.
#[derive(Debug, Clone)]
pub struct PixelLighting {
    surfaces: PixelSurfaces,
    entries: Vec<Entry>,
    /// Direct light of every light but the active one (lx, linear RGB).
    others: Vec<[f32; 3]>,
    active: Option<Active>,
    /// Which pixels see which lights; `None` when nothing can occlude.
    shadows: Option<ShadowBits>,
}

impl PixelLighting {
    /// Per-pixel direct light of `lights` on `surfaces`, with shadow rays through `occluders`
    /// (none: nothing occludes). Casts one shadow ray per (light, pixel facing it).
    pub fn new(surfaces: PixelSurfaces, lights: Vec<PixelLight>, occluders: Option<&Occluders>) -> Self {
        let mut lighting = PixelLighting {
            others: Vec::new(),
            surfaces,
            entries: lights.into_iter().map(Entry::new).collect(),
            active: None,
            shadows: None,
        };
        lighting.sweep(Cast::Every, occluders);
        lighting
    }

    /// Rebuilds the surfaces for a new `view` (a camera move or resize) into `frame` (see
    /// [`PixelSurfaces::rebuild`]) and casts every light's shadow rays again, reusing the
    /// buffers. Errors as [`PixelSurfaces::build`].
    pub fn set_view(
        &mut self,
        frame: &mut Frame,
        mesh: &PatchMesh,
        surfaces: &[Surface],
        view: &View,
        occluders: Option<&Occluders>,
    ) -> Result<()> {
        self.surfaces.rebuild(frame, mesh, surfaces, view)?;
        self.sweep(Cast::Every, occluders);
        self.refresh_active_gamma();
        Ok(())
    }

    /// Replaces every light (a light added or removed): each one's shadow rays are cast again,
    /// the surfaces are kept.
    pub fn set_lights(&mut self, lights: Vec<PixelLight>, occluders: Option<&Occluders>) {
        self.entries = lights.into_iter().map(Entry::new).collect();
        self.active = None;
        self.sweep(Cast::Every, occluders);
    }

    /// The surfaces the light is evaluated on.
    pub fn surfaces(&self) -> &PixelSurfaces {
        &self.surfaces
    }

    /// Number of lights.
    pub fn n_lights(&self) -> usize {
        self.entries.len()
    }

    /// Light `i` as last set.
    pub fn light(&self, i: usize) -> &PixelLight {
        &self.entries[i].light
    }

    /// The light edited last (whose per-pixel terms are cached), if any.
    pub fn active_light(&self) -> Option<usize> {
        self.active.as_ref().map(|a| a.index)
    }

    /// Sets light `i`'s curve, aim, dimmer and colour (aim normalised here). Only what changed is
    /// recomputed: nothing cached for a curve, dimmer or colour change, γ per pixel for a re-aim;
    /// a light other than the active one becomes active first (one pass over all lights).
    ///
    /// Errors (internal): `i` is not a light.
    pub fn set_state(&mut self, i: usize, state: LightState) -> Result<()> {
        self.check(i)?;
        let state = PixelLight::new(DVec3::ZERO, 0.0, state).state;
        let entry = &mut self.entries[i];
        let re_aimed = entry.light.state.aim != state.aim;
        let mut angles_moved = false;
        if entry.light.state.curve != state.curve {
            let lookup = CurveLookup::new(&state.curve);
            angles_moved = !entry.lookup.same_angles(&lookup);
            entry.lookup = lookup;
            entry.table = None;
        }
        entry.light.state = state;
        if self.active_light() != Some(i) {
            self.activate(i);
        } else if re_aimed {
            self.refresh_active_gamma();
        } else if angles_moved {
            self.refresh_active_coordinates();
        }
        Ok(())
    }

    /// Moves light `i` to `position` with luminous radius `radius_m`: its shadow rays are cast
    /// again. Errors (internal): `i` is not a light.
    pub fn set_position(
        &mut self,
        i: usize,
        position: DVec3,
        radius_m: f64,
        occluders: Option<&Occluders>,
    ) -> Result<()> {
        self.check(i)?;
        let entry = &mut self.entries[i];
        entry.light.position = position;
        entry.light.radius_m = radius_m;
        self.sweep(Cast::One(i), occluders);
        if self.active_light() == Some(i) {
            self.refresh_active_gamma();
        }
        Ok(())
    }

    fn check(&self, i: usize) -> Result<()> {
        if i < self.entries.len() {
            Ok(())
        } else {
            Err(Error::internal(format!(
                "pixel lighting: light {i} of {}",
                self.entries.len()
            )))
        }
    }

    /// Makes light `i` the active one: `others` without it, its per-pixel cache built.
    fn activate(&mut self, i: usize) {
        let mut active = self.active.take().unwrap_or_default();
        active.index = i;
        self.active = Some(active);
        self.sweep(Cast::Nothing, None);
        self.refresh_active_gamma();
    }

    /// One parallel pass over the pixels, chunk by chunk ([`shadows::chunk_pixels`]) and light by
    /// light within a chunk: each light's `cosθ / (r² + a²)` and cos γ (f32), its shadow rays
    /// cast again through `occluders` when `cast` names it (else its visibility bits applied),
    /// then its direct light added into `others` with its [`SinHalfTable`] — or, for the active
    /// light, its factor kept in the active cache (docs/DECISIONS.md, "Light-major sum of the
    /// other lights"). With `cast` other than [`Cast::Nothing`] and no `occluders`, nothing
    /// occludes and no bits are kept.
    fn sweep(&mut self, cast: Cast, occluders: Option<&Occluders>) {
        let n = self.surfaces.len();
        let width = self.surfaces.width() as usize;
        let n_lights = self.entries.len();
        let rays = match (cast, occluders) {
            (Cast::Nothing, _) => None,
            (_, None) => {
                self.shadows = None;
                None
            }
            (cast, Some(occluders)) => {
                let fits = self.shadows.as_ref().is_some_and(|b| b.fits(n, width, n_lights));
                if !fits {
                    self.shadows = Some(ShadowBits::new(n, width, n_lights));
                }
                Some((if fits { cast } else { Cast::Every }, occluders))
            }
        };
        let active = self.active_light();
        for (k, entry) in self.entries.iter_mut().enumerate() {
            if Some(k) != active && !entry.is_dark() && entry.table.is_none() {
                entry.table = Some(SinHalfTable::new(&entry.lookup));
            }
        }
        let lights: Vec<SweepLight> = self
            .entries
            .iter()
            .enumerate()
            .map(|(k, entry)| SweepLight::new(k, entry, active, rays.map(|(cast, _)| cast)))
            .collect();
        let chunk = shadows::chunk_pixels(width);
        let n_chunks = n.div_ceil(chunk);
        let mut factors: Vec<Option<&mut [f32]>> = match self.active.as_mut() {
            Some(active) => {
                active.gamma_deg.resize(n, 0.0);
                active.segment.resize(n, 0);
                active.fraction.resize(n, 0.0);
                active.factor.resize(n, 0.0);
                active.factor.chunks_mut(chunk).map(Some).collect()
            }
            None => (0..n_chunks).map(|_| None).collect(),
        };
        let mut bits: Vec<Option<ShadowChunk>> = match self.shadows.as_mut() {
            Some(shadows) => shadows.chunks_mut().into_iter().map(Some).collect(),
            None => (0..n_chunks).map(|_| None).collect(),
        };
        bits.resize_with(n_chunks, || None);
        let surfaces = &self.surfaces;
        self.others.resize(n, [0.0; 3]);
        self.others
            .par_chunks_mut(chunk)
            .zip(factors.par_iter_mut())
            .zip(bits.par_iter_mut())
            .enumerate()
            .for_each(|(c, ((others, active_factor), bits))| {
                let start = c * chunk;
                let (mut factor, mut cos_gamma) = (vec![0.0f32; others.len()], vec![0.0f32; others.len()]);
                let points = ChunkPoints::new(surfaces, start, others.len());
                others.fill([0.0; 3]);
                for (k, light) in lights.iter().enumerate().filter(|(_, l)| l.needed) {
                    light.geometry(&points, &mut factor, &mut cos_gamma);
                    match (bits.as_mut(), rays) {
                        (Some(bits), Some((_, occluders))) if light.cast => {
                            shadows::cast_shadow_rays(
                                occluders,
                                surfaces,
                                start,
                                light.position_m,
                                &mut factor,
                            );
                            bits.store(k, &factor);
                        }
                        (Some(bits), _) => bits.mask(k, &mut factor),
                        (None, _) => {}
                    }
                    match active_factor.as_mut() {
                        Some(out) if active == Some(k) => out.copy_from_slice(&factor),
                        _ => light.add_into(&factor, &cos_gamma, others),
                    }
                }
            });
    }

    /// The active light's γ per pixel for its current aim, and the curve coordinates.
    fn refresh_active_gamma(&mut self) {
        let Some(active) = self.active.as_mut() else {
            return;
        };
        let light = &self.entries[active.index].light;
        let (position, aim) = (light.position, light.state.aim);
        let points = self.surfaces.raw_points();
        active
            .gamma_deg
            .par_chunks_mut(PIXELS_PER_TASK)
            .zip(active.factor.par_chunks(PIXELS_PER_TASK))
            .enumerate()
            .for_each(|(chunk, (gamma, factor))| {
                let start = chunk * PIXELS_PER_TASK;
                for (k, (g, &f)) in gamma.iter_mut().zip(factor).enumerate() {
                    if f == 0.0 {
                        continue;
                    }
                    let d = DVec3::from(points[start + k].map(f64::from)) - position;
                    *g = acos(aim.dot(d) / d.length()).to_degrees() as f32;
                }
            });
        self.refresh_active_coordinates();
    }

    /// The active light's curve coordinate per pixel, from γ.
    fn refresh_active_coordinates(&mut self) {
        let Some(active) = self.active.as_mut() else {
            return;
        };
        let lookup = &self.entries[active.index].lookup;
        let outside = lookup.outside();
        active
            .segment
            .par_chunks_mut(PIXELS_PER_TASK)
            .zip(active.fraction.par_chunks_mut(PIXELS_PER_TASK))
            .zip(active.gamma_deg.par_chunks(PIXELS_PER_TASK))
            .zip(active.factor.par_chunks(PIXELS_PER_TASK))
            .for_each(|(((segment, fraction), gamma), factor)| {
                for (((k, t), &g), &f) in segment.iter_mut().zip(fraction.iter_mut()).zip(gamma).zip(factor) {
                    (*k, *t) = if f == 0.0 {
                        (outside, 0.0)
                    } else {
                        lookup.coordinate_deg(f64::from(g))
                    };
                }
            });
    }

    /// Direct illuminance (lx, linear RGB) of every light at every pixel into `out` (resized to
    /// the pixel count); the background gets 0.
    pub fn direct_into(&self, out: &mut Vec<[f32; 3]>) {
        self.compose_into(None, out);
    }

    /// Direct plus indirect illuminance (lx, linear RGB) at every pixel into `out` (resized to
    /// the pixel count): `indirect_lx` holds per-vertex indirect light of the mesh the surfaces
    /// were built from, interpolated over each pixel's triangle (Gouraud). Negative sums (ringing
    /// of a truncated indirect series) read 0 (+0, never −0); the background gets 0.
    ///
    /// Errors (internal): `indirect_lx` does not hold one value per vertex.
    pub fn illuminance_into(&self, indirect_lx: &[[f32; 3]], out: &mut Vec<[f32; 3]>) -> Result<()> {
        self.check_indirect(indirect_lx)?;
        self.compose_into(Some(indirect_lx), out);
        Ok(())
    }

    /// Shades every pixel of `frame` (built with the surfaces) in one pass: the illuminance of
    /// [`PixelLighting::illuminance_into`] (direct alone when `indirect_lx` is `None`) through
    /// `shader` (photo shaders see the luminance `ρ E / π` of the pixel's surface, false colour the
    /// illuminance; the background gets [`BACKGROUND_RGB`]). With `lux` the illuminance is also
    /// written there (resized), for the legend's isolux lines, picking and PFM files.
    ///
    /// Errors (internal): `indirect_lx` is not one value per vertex, or `frame` is not the
    /// surfaces' size.
    pub fn render_into(
        &self,
        frame: &mut Frame,
        indirect_lx: Option<&[[f32; 3]]>,
        shader: &DisplayShader,
        lux: Option<&mut Vec<[f32; 3]>>,
    ) -> Result<()> {
        if let Some(values) = indirect_lx {
            self.check_indirect(values)?;
        }
        let n = self.surfaces.len();
        if frame.depth.len() != n {
            return Err(Error::internal(format!(
                "pixel lighting: a frame of {} pixels for {n} surface pixels",
                frame.depth.len()
            )));
        }
        let (pixels, _) = frame.pixmap.data_mut().as_chunks_mut::<4>();
        match lux {
            Some(lux) => {
                self.compose_into(indirect_lx, lux);
                self.shade_chunks(pixels, shader, Source::Lux(lux));
            }
            None => self.shade_chunks(pixels, shader, Source::Compose(indirect_lx)),
        }
        Ok(())
    }

    /// Shades `pixels` in parallel chunks of [`PIXELS_PER_TASK`], each in blocks of [`BLOCK`]:
    /// the block's illuminance is taken from `source` (composed into a scratch block on the
    /// stack when it is not composed yet), then shaded in a loop of its own.
    fn shade_chunks(&self, pixels: &mut [[u8; 4]], shader: &DisplayShader, source: Source) {
        let table = match shader {
            DisplayShader::FalseColor(scale) => Some(FalseColorTable::new(scale)),
            DisplayShader::Photo(_) => None,
        };
        pixels
            .par_chunks_mut(PIXELS_PER_TASK)
            .enumerate()
            .for_each(|(chunk, pixels)| {
                let mut scratch = [[0.0f32; 3]; BLOCK];
                for (b, pixels) in pixels.chunks_mut(BLOCK).enumerate() {
                    let start = chunk * PIXELS_PER_TASK + b * BLOCK;
                    let e: &[[f32; 3]] = match source {
                        Source::Lux(lux) => &lux[start..start + pixels.len()],
                        Source::Compose(indirect) => {
                            let e = &mut scratch[..pixels.len()];
                            self.compose_block(start, indirect, e);
                            e
                        }
                    };
                    self.shade_block(start, e, pixels, shader, table.as_ref());
                }
            });
    }

    /// Shades pixels `start..start + pixels.len()` whose illuminance is `e` (lx, linear RGB):
    /// photo shaders see the luminance `ρ E / π` of the pixel's surface, false colour the
    /// illuminance (through `table`, the false-colour scale tabulated for the frame, when given);
    /// the background gets [`BACKGROUND_RGB`]. The shader is matched once, outside the per-pixel
    /// loop.
    #[inline]
    fn shade_block(
        &self,
        start: usize,
        e: &[[f32; 3]],
        pixels: &mut [[u8; 4]],
        shader: &DisplayShader,
        table: Option<&FalseColorTable>,
    ) {
        let background = [BACKGROUND_RGB[0], BACKGROUND_RGB[1], BACKGROUND_RGB[2], 255];
        let triangles = &self.surfaces.triangle_codes()[start..start + pixels.len()];
        match shader {
            DisplayShader::Photo(photo) => {
                let luminance = self.surfaces.patch_luminance_factors();
                let table = tone::table();
                let exposure = photo.exposure() as f32;
                let (mut last, mut f) = (NO_TRIANGLE, [0.0f32; 3]);
                for ((pixel, &t), e) in pixels.iter_mut().zip(triangles).zip(e) {
                    *pixel = if t == NO_TRIANGLE {
                        background
                    } else {
                        if t != last {
                            f = luminance[(t >> 1) as usize].map(|x| x * exposure);
                            last = t;
                        }
                        [
                            tone_srgb8_lit(table, f[0] * e[0]),
                            tone_srgb8_lit(table, f[1] * e[1]),
                            tone_srgb8_lit(table, f[2] * e[2]),
                            255,
                        ]
                    };
                }
            }
            DisplayShader::FalseColor(scale) => {
                for ((pixel, &t), &e) in pixels.iter_mut().zip(triangles).zip(e) {
                    *pixel = if t == NO_TRIANGLE {
                        background
                    } else {
                        let [r, g, b] = table.map_or_else(|| scale.shade(e), |table| table.shade(e));
                        [r, g, b, 255]
                    };
                }
            }
        }
    }

    /// The illuminance (lx, linear RGB) at pixel `i` alone, as [`PixelLighting::illuminance_into`]
    /// computes it (the lux under the cursor); `None` for a pixel outside the image.
    ///
    /// Errors (internal): `indirect_lx` is not one value per vertex.
    pub fn illuminance_at(&self, i: usize, indirect_lx: Option<&[[f32; 3]]>) -> Result<Option<[f32; 3]>> {
        if let Some(values) = indirect_lx {
            self.check_indirect(values)?;
        }
        if i >= self.surfaces.len() {
            return Ok(None);
        }
        let mut value = [[0.0; 3]];
        self.compose_block(i, indirect_lx, &mut value);
        Ok(Some(value[0]))
    }

    fn check_indirect(&self, indirect_lx: &[[f32; 3]]) -> Result<()> {
        let needed = self.surfaces.n_vertices();
        if indirect_lx.len() == needed {
            Ok(())
        } else {
            Err(Error::internal(format!(
                "pixel lighting: {} indirect values for {needed} vertices",
                indirect_lx.len()
            )))
        }
    }

    /// The illuminance `E` (lx, linear RGB, ≥ +0) of pixels `start..start + out.len()` into
    /// `out`: `others`, plus the active light, plus the indirect light interpolated over the
    /// pixel's triangle. The editor's hot path, as one short loop per term (no calls, no
    /// branch on the light: an unlit pixel has factor 0 and the segment of zeros), so the loads
    /// of many pixels are in flight at once.
    #[inline]
    fn compose_block(&self, start: usize, indirect: Option<&[[f32; 3]]>, out: &mut [[f32; 3]]) {
        let range = start..start + out.len();
        let others = &self.others[range.clone()];
        let active = self.active.as_ref().and_then(|active| {
            let entry = &self.entries[active.index];
            (!entry.is_dark()).then_some((active, entry))
        });
        match active {
            Some((active, entry)) => {
                let s = &entry.light.state;
                let scale = [0, 1, 2].map(|ch| (s.color[ch] * s.dimmer) as f32);
                let factor = &active.factor[range.clone()];
                let (segment, fraction) = (&active.segment[range.clone()], &active.fraction[range.clone()]);
                let lit = others.iter().zip(segment).zip(fraction).zip(factor);
                for (e, (((o, &k), &t), &g)) in out.iter_mut().zip(lit) {
                    let intensity = entry.lookup.at_coordinate(k, t) * g;
                    *e = [
                        o[0] + scale[0] * intensity,
                        o[1] + scale[1] * intensity,
                        o[2] + scale[2] * intensity,
                    ];
                }
            }
            None => out.copy_from_slice(others),
        }
        let Some(values) = indirect else {
            for e in out.iter_mut() {
                *e = e.map(non_negative);
            }
            return;
        };
        let triangles = &self.surfaces.triangle_codes()[range.clone()];
        let weights = &self.surfaces.raw_weights()[range];
        let vertices = self.surfaces.patch_vertex_ids();
        // Neighbouring pixels mostly show the same triangle: its corner values are looked up
        // once per run of pixels, not once per pixel.
        let (mut last, mut corner_values) = (NO_TRIANGLE, [[0.0f32; 3]; 3]);
        for ((e, &t), &[wb, wc]) in out.iter_mut().zip(triangles).zip(weights) {
            if t == NO_TRIANGLE {
                *e = e.map(non_negative);
                continue;
            }
            if t != last {
                // Half 0 of a quad is corners 0, 1, 2, half 1 corners 0, 2, 3.
                let v = vertices[(t >> 1) as usize];
                let half = (t & 1) as usize;
                corner_values = [
                    values[v[0] as usize],
                    values[v[1 + half] as usize],
                    values[v[2 + half] as usize],
                ];
                last = t;
            }
            let [va, vb, vc] = corner_values;
            let wa = 1.0 - wb - wc;
            *e = [
                non_negative(e[0] + (wa * va[0] + wb * vb[0] + wc * vc[0])),
                non_negative(e[1] + (wa * va[1] + wb * vb[1] + wc * vc[1])),
                non_negative(e[2] + (wa * va[2] + wb * vb[2] + wc * vc[2])),
            ];
        }
    }

    fn compose_into(&self, indirect: Option<&[[f32; 3]]>, out: &mut Vec<[f32; 3]>) {
        out.resize(self.surfaces.len(), [0.0; 3]);
        out.par_chunks_mut(PIXELS_PER_TASK)
            .enumerate()
            .for_each(|(chunk, out)| {
                for (b, out) in out.chunks_mut(BLOCK).enumerate() {
                    self.compose_block(chunk * PIXELS_PER_TASK + b * BLOCK, indirect, out);
                }
            });
    }

    /// Bytes held per pixel whatever the number of lights (surfaces, `others`, the active
    /// light's cache), and per (light, pixel) (a visibility bit when something can occlude).
    pub fn memory_per_pixel(&self) -> (f64, f64) {
        let shared = PixelSurfaces::BYTES_PER_PIXEL + 12 + 16;
        let per_light = if self.shadows.is_some() { 1.0 / 8.0 } else { 0.0 };
        (shared as f64, per_light)
    }
}

/// `v` scaled to unit length; a `v` already unit to rounding is kept bit for bit, so setting the
/// same state twice changes nothing.
fn unit(v: DVec3) -> DVec3 {
    if (v.length_squared() - 1.0).abs() <= 4.0 * f64::EPSILON {
        v
    } else {
        v.normalize()
    }
}

/// `x` when positive, else +0 (never −0 or NaN: a dark pixel reads 0 lx).
#[inline]
fn non_negative(x: f32) -> f32 {
    if x > 0.0 { x } else { 0.0 }
}
