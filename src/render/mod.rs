//! The software renderer: camera transforms, a perspective-correct Gouraud z-buffer
//! rasterizer writing into a `tiny_skia::Pixmap`, a patch-ID buffer, display modes, overlays
//! and picking. Knows nothing of terminals; the only file format it touches is PNG (goldens).
//!
//! ```text
//! vertex illuminance ─► shade::vertex_attributes ─► render(_into)(mesh, attrs, view, shader) ─► Frame
//!                                                     (clip → raster)          │
//!                                   overlay::draw_lights / draw_crosshair ◄────┤
//!                                   pick::pick(frame, view, mesh, x, y) ◄──────┘
//! ```

pub mod camera;
mod clip;
pub mod exposure;
pub mod golden;
pub mod legend;
pub mod lighting;
pub mod overlay;
pub mod pfm;
pub mod pick;
pub mod plan;
pub mod raster;
pub mod shade;
mod shadows;
pub mod surface;
pub mod text;
pub mod tone;

pub use camera::{Projection, RayBasis, View};
pub use exposure::Exposure;
pub use legend::{Legend, draw_isolux, draw_legend, legend_width, round_levels};
pub use lighting::{PixelLight, PixelLighting};
pub use overlay::{LightMarker, draw_crosshair, draw_lights};
pub use pfm::{encode_pfm, luma_values, write_pfm};
pub use pick::{Pick, aim_direction, pick};
pub use plan::{
    PlanLight, PlanSurface, draw_plan_lights, plan_view, plan_view_beside, work_plane_gather,
    work_plane_indirect, work_plane_mesh,
};
pub use raster::{BACKGROUND_ID, Raster, ScreenTriangle, ScreenVertex, Target, rasterize, rasterize_into};
pub use shade::{
    DisplayMode, DisplayShader, FalseColor, FalseColorTable, LuxScale, Photo, Shader, vertex_attributes,
    vertex_attributes_into,
};
pub use surface::PixelSurfaces;

use tiny_skia::Pixmap;

use crate::error::{Error, Result};
use crate::scene::model::{Patch, PatchMesh};

/// Colour of pixels no patch covers (sRGB8, opaque).
pub const BACKGROUND_RGB: [u8; 3] = [24, 24, 28];

/// Patch id per pixel, row-major from the top-left pixel; [`BACKGROUND_ID`] where no patch is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IdBuffer {
    width: u32,
    height: u32,
    ids: Vec<u32>,
}

impl IdBuffer {
    /// Wraps `ids` (`width × height` values). Errors (internal) when the length is wrong.
    pub fn new(width: u32, height: u32, ids: Vec<u32>) -> Result<IdBuffer> {
        if ids.len() != width as usize * height as usize {
            return Err(Error::internal(format!(
                "id buffer: {} ids for {width}×{height}",
                ids.len()
            )));
        }
        Ok(IdBuffer { width, height, ids })
    }
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// All ids, row-major.
    pub fn as_slice(&self) -> &[u32] {
        &self.ids
    }
    /// The patch at pixel (x, y); `None` for background or outside the image.
    pub fn get(&self, x: u32, y: u32) -> Option<u32> {
        self.index(x, y)
            .map(|i| self.ids[i])
            .filter(|&id| id != BACKGROUND_ID)
    }
    fn index(&self, x: u32, y: u32) -> Option<usize> {
        (x < self.width && y < self.height).then(|| y as usize * self.width as usize + x as usize)
    }
}

/// A rendered frame: the opaque colour image, reversed NDC depth (larger = nearer, 0 = none)
/// and patch ids, all `width × height`.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The colour image (opaque sRGB8).
    pub pixmap: Pixmap,
    /// Depth per pixel, row-major (see [`camera`] for the mapping).
    pub depth: Vec<f32>,
    /// Patch id per pixel.
    pub ids: IdBuffer,
}

impl Frame {
    /// A blank `width × height` frame (transparent black, no depth, all background ids).
    ///
    /// Errors (internal): a side of 0.
    pub fn new(width: u32, height: u32) -> Result<Frame> {
        let n = width as usize * height as usize;
        Ok(Frame {
            pixmap: Pixmap::new(width, height).ok_or_else(|| Error::internal("render: empty image"))?,
            depth: vec![0.0; n],
            ids: IdBuffer::new(width, height, vec![BACKGROUND_ID; n])?,
        })
    }

    /// Depth at pixel (x, y), `None` for background or outside the image.
    pub fn depth_at(&self, x: u32, y: u32) -> Option<f32> {
        let i = self.ids.index(x, y)?;
        (self.ids.ids[i] != BACKGROUND_ID).then_some(self.depth[i])
    }
}

/// Renders `mesh` seen through `view` with per-vertex attributes `attrs` (one linear RGB
/// triple per vertex, e.g. from [`vertex_attributes`]) turned into colours by `shader`.
///
/// Errors (internal): `attrs` not one per vertex, or a patch indexing a missing vertex.
pub fn render(mesh: &PatchMesh, attrs: &[[f32; 3]], view: &View, shader: &impl Shader) -> Result<Frame> {
    let mut frame = Frame::new(view.width(), view.height())?;
    render_into(&mut frame, mesh, attrs, view, shader)?;
    Ok(frame)
}

/// As [`render`], into `frame`: its buffers are reused when it already has the view's size (no
/// image-sized allocation per edit, the editor's path) and replaced otherwise.
/// Errors as [`render`].
pub fn render_into(
    frame: &mut Frame,
    mesh: &PatchMesh,
    attrs: &[[f32; 3]],
    view: &View,
    shader: &impl Shader,
) -> Result<()> {
    let triangles = screen_triangles(mesh, attrs, view)?;
    let (width, height) = (view.width(), view.height());
    if (frame.ids.width, frame.ids.height) != (width, height) {
        *frame = Frame::new(width, height)?;
    }
    let (pixels, _) = frame.pixmap.data_mut().as_chunks_mut::<4>();
    let target = Target::new(width, height, pixels, &mut frame.depth, &mut frame.ids.ids)
        .ok_or_else(|| Error::internal("render: frame buffers do not match the image size"))?;
    let background = [BACKGROUND_RGB[0], BACKGROUND_RGB[1], BACKGROUND_RGB[2], 255];
    rasterize_into(target, &triangles, background, |a| {
        let [r, g, b] = shader.shade(a);
        [r, g, b, 255]
    });
    Ok(())
}

/// Renders the interpolated attribute itself per pixel (`[0; 3]` on background): the value a
/// shader would see, e.g. to read the lux under the cursor. Errors as [`render`].
pub fn render_attributes(mesh: &PatchMesh, attrs: &[[f32; 3]], view: &View) -> Result<Raster<[f32; 3]>> {
    let triangles = screen_triangles(mesh, attrs, view)?;
    Ok(rasterize(
        &triangles,
        view.width(),
        view.height(),
        [0.0; 3],
        |a| a,
    ))
}

/// The screen triangles of `mesh` after checking `attrs` and the patches against it.
fn screen_triangles(mesh: &PatchMesh, attrs: &[[f32; 3]], view: &View) -> Result<Vec<ScreenTriangle>> {
    let n = mesh.n_vertices();
    if attrs.len() != n {
        return Err(Error::internal(format!(
            "render: {} attributes for {n} vertices",
            attrs.len()
        )));
    }
    let bad_patch =
        |p: &Patch| !(3..=4).contains(&p.n_vertices) || p.vertex_ids().iter().any(|&v| v as usize >= n);
    if let Some(pid) = mesh.patches.iter().position(bad_patch) {
        return Err(Error::internal(format!(
            "render: patch {pid} is not 3 or 4 vertices of {n}"
        )));
    }
    Ok(clip::screen_triangles(mesh, attrs, view))
}
