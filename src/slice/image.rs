//! The slice picture on the GPU: uploads the grid, the colormap and the contour segments
//! (bucketed into 8x8-pixel tiles), runs the slice pass over bands of rows and reads back one
//! [`SlicePixel`] per pixel, with the renderer's band loop ([`crate::passes::Bands`]).

use std::sync::Arc;

use ash::vk;
use glam::DVec2;

use super::contour::Contour;
use super::plane::PlaneGrid;
use crate::field::interpolant::Interpolant;
use crate::gpu::{Buffer, ComputePipeline, Context, GpuError};
use crate::passes::slice::{self as pass, SliceInputs, SliceParams, SlicePass, SlicePixel};
use crate::passes::Bands;
use crate::render::GpuGrid;
use crate::scene::Inside;

/// The colormap's name, as recorded in the EXR header.
pub const COLORMAP_NAME: &str = "RdBu (colorous RED_BLUE)";

/// The slice colormap: 256 linear RGBA entries of colorous's RdBu (sRGB-decoded). Entry 0 (dark
/// red) is the inside end, entry 255 (dark blue) the outside end, white the isovalue.
pub fn colormap() -> Vec<[f32; 4]> {
    crate::render::linear_colormap(colorous::RED_BLUE)
}

/// `|value - isovalue|` mapped to the colormap's ends: the largest on the plane (1 where the
/// plane is all at the isovalue).
pub fn colormap_half_range(plane: &PlaneGrid, isovalue: f64) -> f64 {
    let (lo, hi) = plane.range();
    let r = (hi - isovalue).abs().max((lo - isovalue).abs());
    if r > 0.0 && r.is_finite() {
        r
    } else {
        1.0
    }
}

/// How to draw a slice picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SliceStyle {
    pub width: u32,
    pub height: u32,
    pub isovalue: f64,
    pub inside: Inside,
    /// `|value - isovalue|` at the colormap's ends.
    pub half_range: f64,
    /// Contour lines: width in pixels and linear RGBA.
    pub line_width: f32,
    pub line_color: [f32; 4],
}

/// A slice picture read back from the GPU, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct SliceImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<SlicePixel>,
}

/// Contour segments in pixel coordinates, bucketed by 8x8-pixel tile (CSR).
struct Tiles {
    start: Vec<u32>,
    members: Vec<u32>,
    segments: Vec<[f32; 4]>,
    per_row: u32,
}

fn tiles(plane: &PlaneGrid, contours: &[Contour], style: &SliceStyle) -> Tiles {
    let (w, h) = (style.width as f64, style.height as f64);
    let cells = plane.cells();
    let to_pixel = |q: DVec2| DVec2::new(q.x * w / cells[0] as f64, h - q.y * h / cells[1] as f64);
    let mut segments = Vec::new();
    for c in contours {
        let n = c.points.len();
        let count = if c.closed { n } else { n - 1 };
        for i in 0..count {
            let (a, b) = (to_pixel(c.points[i]), to_pixel(c.points[(i + 1) % n]));
            segments.push([a.x as f32, a.y as f32, b.x as f32, b.y as f32]);
        }
    }
    let tile = pass::GROUP as f64;
    let per_row = style.width.div_ceil(pass::GROUP);
    let rows = style.height.div_ceil(pass::GROUP);
    let reach = 0.5 * style.line_width as f64 + 1.0;
    let span = |lo: f32, hi: f32, count: u32| {
        let first = ((lo as f64 - reach) / tile).floor().max(0.0) as u32;
        let last = ((hi as f64 + reach) / tile).floor().clamp(0.0, (count - 1) as f64) as u32;
        first..=last
    };
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); (per_row * rows) as usize];
    for (n, s) in segments.iter().enumerate() {
        for ty in span(s[1].min(s[3]), s[1].max(s[3]), rows) {
            for tx in span(s[0].min(s[2]), s[0].max(s[2]), per_row) {
                lists[(ty * per_row + tx) as usize].push(n as u32);
            }
        }
    }
    let mut start = Vec::with_capacity(lists.len() + 1);
    let mut members = Vec::new();
    for l in &lists {
        start.push(members.len() as u32);
        members.extend_from_slice(l);
    }
    start.push(members.len() as u32);
    Tiles { start, members, segments, per_row }
}

/// Owns the slice pipelines (one per interpolant drawn, built when first needed) and the
/// colormap; draws any number of slices.
pub struct SliceRenderer {
    ctx: Arc<Context>,
    pipelines: Vec<(Interpolant, ComputePipeline)>,
    colormap: Buffer,
}

impl SliceRenderer {
    pub fn new(ctx: &Arc<Context>) -> Result<Self, GpuError> {
        let colormap = Buffer::upload(
            ctx,
            "slice colormap",
            &colormap(),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        Ok(SliceRenderer { ctx: ctx.clone(), pipelines: Vec::new(), colormap })
    }

    pub fn context(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// Draws `plane` of the uploaded grid with `contours` (plane index coordinates) over it.
    pub fn render(
        &mut self,
        grid: &GpuGrid,
        plane: &PlaneGrid,
        contours: &[Contour],
        style: &SliceStyle,
    ) -> Result<SliceImage, GpuError> {
        let ctx = &self.ctx;
        let (width, height) = (style.width, style.height);
        if width == 0 || height == 0 {
            return Err(GpuError::Bug(format!("cannot draw an empty {width}x{height} slice")));
        }
        let t = tiles(plane, contours, style);
        let cells = plane.cells();
        let params = SliceParams {
            axes: [plane.axes.0 as u32, plane.axes.1 as u32, plane.axis.index() as u32, 0],
            dims: [grid.dims[0] as i32, grid.dims[1] as i32, grid.dims[2] as i32, 0],
            image: [width, height, t.per_row, 0],
            plane: [
                plane.w() as f32,
                style.isovalue as f32,
                if style.inside == Inside::Below { 1.0 } else { -1.0 },
                style.half_range as f32,
            ],
            scale: [
                (cells[0] as f64 / width as f64) as f32,
                (cells[1] as f64 / height as f64) as f32,
                0.5 * style.line_width,
                0.0,
            ],
            line: style.line_color,
        };
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let params_buf = Buffer::upload(
            ctx,
            "slice params",
            std::slice::from_ref(&params),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
        )?;
        let start = Buffer::upload(ctx, "slice tile starts", &t.start, storage)?;
        let members = Buffer::upload(ctx, "slice tile segments", &t.members, storage)?;
        let segments = Buffer::upload(ctx, "slice segments", &t.segments, storage)?;

        let bands = Bands::<SlicePixel>::new(ctx, "slice pixels", width, height)?;
        if !self.pipelines.iter().any(|(i, _)| *i == plane.interp) {
            self.pipelines.push((plane.interp, pass::pipeline(ctx, plane.interp)?));
        }
        let pipeline = self.pipelines.iter().find(|(i, _)| *i == plane.interp).map(|(_, p)| p);
        let pass = SlicePass::new(
            pipeline.ok_or_else(|| GpuError::Bug("the slice pipeline was just built".into()))?,
            SliceInputs {
                params: &params_buf,
                grid: grid
                    .image("a slice of a brick pool")
                    .map_err(|e| GpuError::Bug(e.to_string()))?,
                pixels: &bands.out,
                colormap: &self.colormap,
                tile_starts: &start,
                tile_segments: &members,
                segments: &segments,
            },
        )?;
        let (pixels, _) = bands.run(pass.name(), |rec, band| {
            pass.record(rec, width, band);
            Ok(())
        })?;
        Ok(SliceImage { width, height, pixels })
    }
}
