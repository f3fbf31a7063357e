//! `isoview slice SCENE.toml -o OUT.exr --axis x|y|z --at C [--json C.json] [--svg C.svg]
//! [--png P.png] [--set K=V]... [--time T]`, and the `--slice` branch of `isoview probe`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec2;
use serde_json::{json, Value};

use super::console::{note, say};
use super::{Cli, Failure};
use crate::render::GpuGrid;
use crate::scene;
use crate::slice::{self, export, Axis, PlaneGrid, SliceRenderer};
use crate::vocab::echo;

#[derive(clap::Args, Debug)]
pub struct SliceArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Output EXR: R, G, B, A (colormap with the contours), value (the field), contour
    /// (line coverage).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The axis the plane is perpendicular to.
    #[arg(long, value_enum, ignore_case = true)]
    pub axis: Axis,
    /// World coordinate of the plane along the axis (inside the grid box).
    #[arg(long, allow_hyphen_values = true, value_parser = super::number)]
    pub at: f64,
    /// Write the contours as JSON (world coordinates).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the contours as SVG.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Also write an 8-bit sRGB preview of the picture.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Override a scene key (as for `render`), e.g. --set slice.ambiguity=sample.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Time of the field in seconds (`t` in expr fields).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = super::number)]
    pub time: f64,
    /// Largest picture, in pixels (width x height): it is drawn whole in memory.
    #[arg(long, allow_hyphen_values = true, value_name = "N", default_value_t = scene::DEFAULT_MAX_PIXELS,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub max_pixels: u64,
}

fn check_extension(path: &Path, ext: &str, flag: &str) -> Result<(), Failure> {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case(ext) => Ok(()),
        _ => Err(Failure::input(format!(
            "{flag} {}: the file name must end in .{ext}",
            path.display()
        ))),
    }
}

pub fn run(cli: &Cli, args: &SliceArgs) -> Result<i32, Failure> {
    let started = Instant::now();
    check_extension(&args.output, "exr", "-o")?;
    for (p, ext, flag) in [(&args.json, "json", "--json"), (&args.svg, "svg", "--svg")] {
        if let Some(p) = p {
            check_extension(p, ext, flag)?;
        }
    }
    if let Some(p) = &args.png {
        check_extension(p, "png", "--png")?;
    }
    super::finite("--at", args.at)?;
    super::finite("--time", args.time)?;
    let scene = super::load_scene(&args.scene, &args.sets)?;
    super::refuse_interpolation(&scene, crate::field::interpolant::Reader::Slice)?;
    let mut outputs = vec![("-o", args.output.as_path())];
    for (p, flag) in [(&args.png, "--png"), (&args.json, "--json"), (&args.svg, "--svg")] {
        if let Some(p) = p {
            outputs.push((flag, p.as_path()));
        }
    }
    super::check_outputs(&outputs, &scene)?;
    let grid = scene.field.sample(args.time).map_err(Failure::input)?;
    let slice::Planned { plane, mut set, style } =
        slice::plan(&scene, &grid, args.axis, args.at, args.time).map_err(|e| {
            Failure::input(e.located(&format!("--at {}", crate::vocab::echo_number(args.at))))
        })?;
    slice::check_picture(&scene, &style, args.max_pixels, "slice").map_err(Failure::input)?;
    // Several isovalues: one contour set per surface (the picture's colours centre on the
    // first; every set's lines are drawn; the JSON lists them per surface).
    let mut per_surface = vec![(scene.surface.isovalue, set.contours.clone())];
    for k in 1..scene.surface.count {
        let one = scene.single_surface(k);
        let s = slice::scene_contours(&one, &grid, &plane, args.time).map_err(Failure::input)?;
        per_surface.push((one.surface.isovalue, s.contours.clone()));
        set.contours.extend(s.contours);
        set.stats.ambiguous += s.stats.ambiguous;
        set.stats.joined += s.stats.joined;
    }
    let (width, height) = (style.width, style.height);
    let iso = scene.surface.isovalue;

    let ctx = cli.gpu()?;
    let mut renderer = SliceRenderer::new(&ctx)?;
    // Over the device's 3D image extent: the input's size, named (exit 2), not a GPU fault.
    scene.field.check_image_extent(ctx.info.max_image_dimension_3d).map_err(Failure::input)?;
    let gpu_grid = GpuGrid::upload(&ctx, &grid)?;
    let picture = renderer.render(&gpu_grid, &plane, &set.contours, &style)?;

    let attributes = slice::attributes(
        &scene,
        &plane,
        &style,
        (&ctx.info.name, &ctx.info.driver_info),
        args.time,
    );
    export::write_exr(&args.output, &picture, &attributes).map_err(Failure::input)?;
    if let Some(p) = &args.png {
        export::write_png(p, &picture).map_err(Failure::input)?;
    }
    if let Some(p) = &args.json {
        if scene.surface.several() {
            let surfaces: Vec<(f64, &[_])> =
                per_surface.iter().map(|(iso, c)| (*iso, c.as_slice())).collect();
            export::write_json_surfaces(p, &plane, &scene.field.placement, &surfaces)
        } else {
            export::write_json(p, &plane, &scene.field.placement, iso, &set.contours)
        }
        .map_err(Failure::input)?;
    }
    if let Some(p) = &args.svg {
        let title = slice::svg_title(&plane, &args.scene.display().to_string(), iso);
        export::write_svg(p, &plane, &set.contours, width, height, &title)
            .map_err(Failure::input)?;
    }
    let (closed, open) = set.counts();
    note!(
        "slice {} = {} ({}x{} px): {closed} closed and {open} open contour(s), {} \
         ambiguous cell(s) by \"{}\" ({} joined){} on {} in {:.0} ms -> {}",
        plane.axis.name(),
        crate::vocab::echo_number(plane.at),
        width,
        height,
        set.stats.ambiguous,
        scene.slice.ambiguity.name(),
        set.stats.joined,
        if set.stats.on_source {
            format!(", {} cells refined on the source", set.stats.cells)
        } else {
            String::new()
        },
        ctx.info.name,
        started.elapsed().as_secs_f64() * 1e3,
        args.output.display()
    );
    Ok(0)
}

/// Parses `--slice z=C`.
fn parse_slice(s: &str) -> Result<(Axis, f64), String> {
    let bad = || format!("--slice {}: expected AXIS=C, e.g. z=0.25", echo(s));
    let (a, c) = s.split_once('=').ok_or_else(bad)?;
    let axis = Axis::parse(a).ok_or_else(bad)?;
    let c: f64 = c.trim().parse().map_err(|_| bad())?;
    if !c.is_finite() {
        return Err(bad());
    }
    Ok((axis, c))
}

/// Parses `--segment u0,v0,u1,v1`.
fn parse_segment(s: &str) -> Result<(DVec2, DVec2), String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--segment {}: expected four numbers u0,v0,u1,v1", echo(s)))?;
    if v.len() != 4 || v.iter().any(|x| !x.is_finite()) {
        return Err(format!("--segment {}: expected four finite numbers u0,v0,u1,v1", echo(s)));
    }
    Ok((DVec2::new(v[0], v[1]), DVec2::new(v[2], v[3])))
}

/// `isoview probe SCENE --slice AXIS=C --segment u0,v0,u1,v1 [--json]`: the crossings of the
/// bilinear interpolant on the plane along the segment (world `(u, v)`: the plane's right and
/// up axes, as in the slice picture), cell by cell with the cells' corner values and quadratics.
pub fn probe(
    scene_path: &Path,
    sets: &[String],
    time: f64,
    slice_arg: &str,
    segment: Option<&str>,
    as_json: bool,
) -> Result<i32, Failure> {
    let (axis, at) = parse_slice(slice_arg).map_err(Failure::input)?;
    let segment = segment.ok_or_else(|| Failure::input("--slice needs --segment u0,v0,u1,v1"))?;
    let (a, b) = parse_segment(segment).map_err(Failure::input)?;
    let scene = scene::load(scene_path, sets).map_err(Failure::input)?;
    super::refuse_interpolation(&scene, crate::field::interpolant::Reader::SegmentProbe)?;
    let grid = scene.field.sample(time).map_err(Failure::input)?;
    let plane = PlaneGrid::new(&grid, axis, at)
        .map_err(|e| Failure::input(e.located(&format!("--slice {}", echo(slice_arg)))))?;
    let (iso, inside) = (scene.surface.isovalue, scene.surface.inside);
    let probe = slice::probe_segment(&plane, a, b, iso, inside);
    // The segment is in the plane's (u, v), the grid's own frame; root points are reported in
    // world space.
    let placement = &scene.field.placement;
    let names = ["x", "y", "z"];
    let (u, v) = (names[plane.axes.0], names[plane.axes.1]);

    if as_json {
        let cells: Vec<Value> = probe
            .cells
            .iter()
            .map(|c| {
                json!({
                    "cell": c.cell,
                    "corners": {"v00": c.corners[0], "v10": c.corners[1], "v01": c.corners[2], "v11": c.corners[3]},
                    "t": [c.t.0, c.t.1],
                    "local_in": [c.local_in.x, c.local_in.y],
                    "local_out": [c.local_out.x, c.local_out.y],
                    "quadratic": c.quadratic,
                    "roots": c.roots.iter().map(|r| json!({
                        "s": r.s, "t": r.t, "point": placement.point_to_world(r.point).to_array(), "kind": r.kind.name(),
                    })).collect::<Vec<_>>(),
                })
            })
            .collect();
        let report = json!({
            "scene": scene_path.display().to_string(),
            "axis": axis.name(),
            "at": at,
            "plane_axes": [u, v],
            "layer": plane.layer,
            "weight": plane.weight,
            "isovalue": iso,
            "inside": inside.name(),
            "segment": [[a.x, a.y], [b.x, b.y]],
            "span": probe.span.map(|(t0, t1)| json!([t0, t1])),
            "cells": cells,
        });
        say!("{}", serde_json::to_string_pretty(&report).map_err(Failure::input)?)?;
        return Ok(0);
    }

    say!(
        "slice {} = {at}: {u} right, {v} up; between grid layers {} and {} at {:.6}; isovalue \
         {iso}, inside {}",
        axis.name(),
        plane.layer,
        plane.layer + 1,
        plane.weight,
        inside.name()
    )?;
    say!("segment ({u}, {v}) from ({}, {}) to ({}, {}), t in [0, 1]", a.x, a.y, b.x, b.y)?;
    let Some((t0, t1)) = probe.span else {
        say!(
            "the segment misses the plane's box ({u} {} .. {}, {v} {} .. {})",
            plane.min.x,
            plane.max.x,
            plane.min.y,
            plane.max.y
        )?;
        return Ok(0);
    };
    say!("inside the box for t in [{t0:.6}, {t1:.6}], {} cell(s)", probe.cells.len())?;
    let mut count = 0;
    for c in &probe.cells {
        let k = c.corners;
        say!(
            "  cell [{}, {}]  t [{:.6}, {:.6}]  corners v00 {:.6} v10 {:.6} v01 {:.6} v11 {:.6}",
            c.cell[0],
            c.cell[1],
            c.t.0,
            c.t.1,
            k[0],
            k[1],
            k[2],
            k[3]
        )?;
        let q = c.quadratic;
        say!(
            "    f - iso = {:.6e} + {:.6e} s + {:.6e} s^2, s in [0, 1] from local ({:.4}, {:.4}) \
             to ({:.4}, {:.4})",
            q[0],
            q[1],
            q[2],
            c.local_in.x,
            c.local_in.y,
            c.local_out.x,
            c.local_out.y
        )?;
        for r in &c.roots {
            count += 1;
            say!(
                "    root: s = {:.9}  t = {:.9}  at [{:.6}, {:.6}, {:.6}]  ({})",
                r.s,
                r.t,
                placement.point_to_world(r.point).x,
                placement.point_to_world(r.point).y,
                placement.point_to_world(r.point).z,
                r.kind.name()
            )?;
        }
    }
    say!("{count} root(s)")?;
    Ok(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slice_and_segment_arguments() {
        assert_eq!(parse_slice("z=0.25"), Ok((Axis::Z, 0.25)));
        assert_eq!(parse_slice("X = -1"), Ok((Axis::X, -1.0)));
        assert!(parse_slice("w=1").is_err());
        assert!(parse_slice("z").is_err());
        assert!(parse_slice("z=inf").is_err());
        assert_eq!(
            parse_segment("-1, 0, 1,0.5"),
            Ok((DVec2::new(-1.0, 0.0), DVec2::new(1.0, 0.5)))
        );
        assert!(parse_segment("1,2,3").is_err());
        assert!(parse_segment("1,2,3,a").is_err());
    }
}
