//! What the ray through one pixel meets, from the f64 references (`isoview probe --pixel`,
//! the server's `/api/probe`), through the scene's `field.interpolation`: every cell the exact
//! walk visits with its samples (trilinear: the 8 corners, the cubic along the segment and its
//! derivative roots; the tricubic interpolants: the 64 samples, the segment's degree-9
//! Bernstein coefficients and the isolation's leaves), the roots found and their Newton
//! iterates; for nearest, every voxel of the voxel walk with its value and state; where
//! fixed-step with the scene's `steps` finds (or misses) its first crossing; and how far apart
//! the two are. [`PixelProbe::json`] is the report `probe --json` prints.

use glam::DVec3;
use serde_json::{json, Value};

use crate::camera::Camera;
use crate::field::interpolant::{Interpolant, Interpolated};
use crate::field::Grid;
use crate::reference::analytic::{self, AnalyticHit, AnalyticOptions, CellVisit, Hit, Polynomial};
use crate::reference::fixed_step::{self, March, Sampling};
use crate::reference::voxels::{self, VoxelTrace, VoxelVisit};
use crate::scene::Scene;

/// The references' answers for one pixel.
pub struct PixelProbe {
    pub pixel: (u32, u32),
    /// The pixel's ray in world space: its origin (the eye, or the pixel's point on an
    /// orthographic camera's image plane) and unit direction.
    pub origin: DVec3,
    pub dir: DVec3,
    pub options: AnalyticOptions,
    /// The scene's interpolant (never `device`: only sampled, it has no exact trace).
    pub interpolation: Interpolant,
    pub exact: AnalyticHit,
    /// The cells of the exact walk (empty for nearest).
    pub visits: Vec<CellVisit>,
    /// Nearest's voxels (empty for the others); `exact` is then its voxel walk's, with the
    /// inside voxel as the hit's cell.
    pub voxels: Vec<VoxelVisit>,
    pub fixed: March,
}

/// Parses `X,Y` (a pixel of a `width` × `height` image); the error is the CLI's message.
pub fn parse_pixel(s: &str, width: u32, height: u32) -> Result<(u32, u32), String> {
    let shown = crate::vocab::echo(s);
    let (x, y) = s.split_once(',').ok_or_else(|| format!("--pixel {shown}: expected X,Y"))?;
    let outside = || format!("--pixel {shown}: outside the {width}x{height} image");
    let parse = |v: &str| {
        v.trim().parse::<u32>().map_err(|e| match e.kind() {
            // A whole number past u32 is an index, past every image's edge.
            std::num::IntErrorKind::PosOverflow => outside(),
            _ => format!("--pixel {shown}: `{}` is not a pixel index", crate::vocab::echo(v)),
        })
    };
    let (x, y) = (parse(x)?, parse(y)?);
    if x >= width || y >= height {
        return Err(outside());
    }
    Ok((x, y))
}

fn v3(v: DVec3) -> Value {
    json!([v.x, v.y, v.z])
}

fn visit_json(v: &CellVisit) -> Value {
    let mut out = json!({
        "cell": v.cell,
        "corners": v.samples,
        "t": [v.t_in, v.t_out],
        "local_in": v3(v.q_in),
        "local_out": v3(v.q_out),
        "derivative_roots": v.derivative_roots,
        "splits": v.splits.iter().map(|s| json!({"u": s.u, "g": s.g, "inside": s.inside})).collect::<Vec<_>>(),
        "roots": v.roots.iter().map(|r| json!({
            "crossing": r.crossing, "u": r.u, "t": r.t, "entering": r.entering,
            "exact": r.exact, "bracket": [r.bracket.0, r.bracket.1], "newton_iterates": r.iterates,
        })).collect::<Vec<_>>(),
    });
    // Trilinear's cubic keeps its key; the tricubic interpolants' segment is a Bernstein
    // polynomial, with the leaves its isolation cut it into.
    match &v.coefficients {
        Polynomial::Monomial(c) => out["cubic"] = json!(c),
        Polynomial::Bernstein(b) => {
            out["bernstein"] = json!(b);
            out["leaves"] = json!(v
                .leaves
                .iter()
                .map(|l| json!({"u": [l.u.0, l.u.1], "variations": l.variations, "resolved": l.resolved}))
                .collect::<Vec<_>>());
        }
    }
    if v.missing {
        out["missing"] = json!(missing_note(v));
    }
    out
}

/// Nearest's voxel walk as the probe's exact answer: the hit's cell is the inside voxel's
/// point, its local coordinates the hit's offset from that point (in `[-½, ½]`), and the cells
/// counted are voxels.
fn voxel_hit(v: &VoxelTrace) -> AnalyticHit {
    AnalyticHit {
        hit: v.hit.map(|h| {
            let voxel = h.voxel.map(|c| c as i32);
            let at = DVec3::new(voxel[0] as f64, voxel[1] as f64, voxel[2] as f64);
            Hit {
                t: h.t,
                position: h.position,
                normal: h.normal,
                cell: voxel,
                local: h.grid_coords - at,
                entering: h.entering,
                crossing: h.crossing,
            }
        }),
        span: v.span,
        inside_at_start: v.inside_at_start,
        cells_visited: v.voxels_visited,
        cells_total: v.voxels_total,
        crossings: v.crossings,
    }
}

/// Why a missing cell has no surface (`field.nan = "empty"`), as the probe reports it.
pub fn missing_note(v: &CellVisit) -> String {
    let [i, j, k] = v.cell;
    format!("cell ({i}, {j}, {k}) holds a non-finite sample: no surface")
}

/// Why fixed-step found no crossing, as the probe reports it (text, `--json`'s `"miss"`, the
/// page): a ray that takes no sample, or one whose samples are all missing data, has no
/// "closest sample" to name (its margin would print as NaN or inf).
pub fn march_miss_note(m: &March) -> String {
    if m.steps == 0 {
        "no sample taken: the ray misses the field's box (or the clip)".to_string()
    } else if !m.margin.is_finite() {
        format!("no crossing found: none of the {} samples on the ray is finite", m.steps)
    } else {
        format!("no crossing found (closest sample is {:.3e} from the isovalue)", m.margin)
    }
}

impl PixelProbe {
    /// Traces pixel `(px, py)` of `scene` (inside its image) through `grid`, the scene's field
    /// sampled at the time of interest.
    pub fn new(scene: &Scene, grid: &Grid, px: u32, py: u32) -> Self {
        // Traced in the grid's own frame (as every method does); the ray and the hits are
        // reported in world space. Cells, t and cell-local coordinates are the same in both.
        let world = Camera::new(&scene.camera, &scene.image);
        let cam = Camera::for_scene(scene);
        let (origin, dir) = cam.ray(px, py);
        let (iso, inside) = (scene.surface.isovalue, scene.surface.inside);
        let clip = scene.clip.in_grid_frame(&scene.field.placement);
        let options =
            AnalyticOptions { newton_steps: scene.render.newton_steps, clip, ..Default::default() };
        let interpolation = scene.field.interpolation;
        let (mut exact, visits, voxels) = match interpolation {
            Interpolant::Nearest => {
                let (v, list) = voxels::trace_detailed(grid, iso, inside, origin, dir, &options);
                (voxel_hit(&v), Vec::new(), list)
            }
            // Callers refuse `device` first (`Reader::Probe`); it is traced as what it filters,
            // the trilinear field, were one to reach here.
            _ => {
                let field = Interpolated::new(
                    grid,
                    match interpolation {
                        Interpolant::Device => Interpolant::Trilinear,
                        other => other,
                    },
                );
                let (e, v) = analytic::trace_detailed_interpolated(
                    &field, iso, inside, origin, dir, &options,
                );
                (e, v, Vec::new())
            }
        };
        let sampling = Sampling::new(interpolation);
        let steps = scene.render.steps;
        let mut fixed =
            fixed_step::march_sampled(grid, sampling, iso, inside, origin, dir, steps, &clip);
        let placement = &scene.field.placement;
        if let Some(h) = exact.hit.as_mut() {
            (h.position, h.normal) =
                (placement.point_to_world(h.position), placement.vector_to_world(h.normal));
        }
        if let Some(h) = fixed.hit.as_mut() {
            (h.position, h.normal) =
                (placement.point_to_world(h.position), placement.vector_to_world(h.normal));
        }
        let (origin, dir) = world.ray(px, py);
        PixelProbe {
            pixel: (px, py),
            origin,
            dir,
            options,
            interpolation,
            exact,
            visits,
            voxels,
            fixed,
        }
    }

    /// How far apart the exact hit and fixed-step's crossing are, when both exist.
    pub fn hit_distance(&self) -> Option<f64> {
        match (&self.exact.hit, &self.fixed.hit) {
            (Some(a), Some(f)) => Some((a.position - f.position).length()),
            _ => None,
        }
    }

    /// The report of `probe --json`; `scene_name` is the scene file as given.
    pub fn json(&self, scene: &Scene, scene_name: &str) -> Value {
        let (exact, fixed) = (&self.exact, &self.fixed);
        let inside = scene.surface.inside;
        let mut report = json!({
            "scene": scene_name,
            "pixel": [self.pixel.0, self.pixel.1],
            "image": [scene.image.width, scene.image.height],
            "isovalue": scene.surface.isovalue,
            "inside": format!("{inside:?}").to_lowercase(),
            "ray": {"origin": v3(self.origin), "direction": v3(self.dir)},
            "box_span": exact.span.map(|(a, b)| json!([a, b])),
            "analytic": {
                "newton_steps": self.options.newton_steps,
                "hit": exact.hit.as_ref().map(|h| json!({
                    "t": h.t, "position": v3(h.position), "normal": v3(h.normal), "cell": h.cell,
                    "local": v3(h.local),
                })),
                "interpolation": self.interpolation.name(),
                "cells_visited": exact.cells_visited,
                "crossings": exact.crossings,
                "inside_at_start": exact.inside_at_start,
                "cells": self.visits.iter().map(visit_json).collect::<Vec<_>>(),
            },
            "fixed_step": {
                "steps": scene.render.steps,
                "samples_taken": fixed.steps,
                "hit": fixed.hit.as_ref().map(|h| json!({
                    "t": h.t, "position": v3(h.position), "normal": v3(h.normal), "cell": h.cell,
                })),
                "closest_sample_to_isovalue": fixed.margin,
                "miss": fixed.hit.is_none().then(|| march_miss_note(fixed)),
            },
            "hit_distance": self.hit_distance(),
        });
        if let Some(p) = crate::output::describe_placement(&scene.field.placement) {
            report["placement"] = json!(p);
        }
        if self.interpolation == Interpolant::Nearest {
            report["analytic"]["voxels"] = json!(self
                .voxels
                .iter()
                .map(|v| json!({
                    "voxel": v.voxel, "value": v.value, "inside": v.inside, "t": [v.t_in, v.t_out],
                }))
                .collect::<Vec<_>>());
        }
        report
    }
}
