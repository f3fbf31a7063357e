//! `isoview probe SCENE --pixel X,Y [--json]`: what the ray through one pixel meets, from the f64
//! references: every cell the exact walk visits with its 8 corner values, the cubic along the
//! segment, its derivative roots, the roots found and their Newton iterates; where fixed-step
//! with the scene's `steps` finds (or misses) its first crossing; and how far apart the two are.
//! The tool for "why does this pixel look wrong".

use std::path::PathBuf;

use glam::DVec3;
use serde_json::{json, Value};

use super::{Cli, Failure};
use crate::camera::Camera;
use crate::reference::analytic::{self, AnalyticOptions, CellVisit};
use crate::reference::fixed_step;
use crate::scene;

#[derive(clap::Args, Debug)]
pub struct ProbeArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Pixel column and row (row 0 at the top), e.g. --pixel 120,64.
    #[arg(long, value_name = "X,Y", required_unless_present = "slice", conflicts_with = "slice")]
    pub pixel: Option<String>,
    /// Probe a slicing plane instead of a pixel, e.g. --slice z=0.1 (needs --segment).
    #[arg(long, value_name = "AXIS=C", requires = "segment")]
    pub slice: Option<String>,
    /// With --slice: the segment u0,v0,u1,v1 in the plane's (u, v) world coordinates (u right,
    /// v up, as in the slice picture); prints the bilinear field's crossings along it.
    #[arg(long, value_name = "U0,V0,U1,V1", requires = "slice", allow_hyphen_values = true)]
    pub segment: Option<String>,
    /// Override a scene key (as for `render`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Time of the field in seconds.
    #[arg(long, default_value_t = 0.0)]
    pub time: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

fn parse_pixel(s: &str, width: u32, height: u32) -> Result<(u32, u32), String> {
    let (x, y) = s.split_once(',').ok_or_else(|| format!("--pixel {s}: expected X,Y"))?;
    let parse = |v: &str| {
        v.trim().parse::<u32>().map_err(|_| format!("--pixel {s}: `{v}` is not a pixel index"))
    };
    let (x, y) = (parse(x)?, parse(y)?);
    if x >= width || y >= height {
        return Err(format!("--pixel {s}: outside the {width}x{height} image"));
    }
    Ok((x, y))
}

fn v3(v: DVec3) -> Value {
    json!([v.x, v.y, v.z])
}

fn visit_json(v: &CellVisit) -> Value {
    json!({
        "cell": v.cell,
        "corners": v.corners,
        "t": [v.t_in, v.t_out],
        "local_in": v3(v.q_in),
        "local_out": v3(v.q_out),
        "cubic": v.coefficients,
        "derivative_roots": v.derivative_roots,
        "splits": v.splits.iter().map(|s| json!({"u": s.u, "g": s.g, "inside": s.inside})).collect::<Vec<_>>(),
        "roots": v.roots.iter().map(|r| json!({
            "crossing": r.crossing, "u": r.u, "t": r.t, "entering": r.entering,
            "exact": r.exact, "bracket": [r.bracket.0, r.bracket.1], "newton_iterates": r.iterates,
        })).collect::<Vec<_>>(),
    })
}

pub fn run(_cli: &Cli, args: &ProbeArgs) -> Result<i32, Failure> {
    if let Some(s) = &args.slice {
        let segment = args.segment.as_deref();
        return super::slice::probe(&args.scene, &args.sets, args.time, s, segment, args.json);
    }
    let scene = scene::load(&args.scene, &args.sets).map_err(Failure::input)?;
    let pixel = args.pixel.as_deref().ok_or_else(|| Failure::input("--pixel X,Y is missing"))?;
    let (px, py) =
        parse_pixel(pixel, scene.image.width, scene.image.height).map_err(Failure::input)?;
    let grid = scene.field.sample(args.time).map_err(Failure::input)?;
    // Traced in the grid's own frame (as every method does); the ray and the hits are
    // reported in world space. Cells, t and cell-local coordinates are the same in both.
    let world = Camera::new(&scene.camera, &scene.image);
    let cam = Camera::for_scene(&scene);
    let (origin, dir) = cam.ray(px, py);
    let (iso, inside) = (scene.surface.isovalue, scene.surface.inside);
    let clip = scene.clip.in_grid_frame(&scene.field.placement);
    let opts =
        AnalyticOptions { newton_steps: scene.render.newton_steps, clip, ..Default::default() };
    let (mut exact, visits) = analytic::trace_detailed(&grid, iso, inside, origin, dir, &opts);
    let mut fixed =
        fixed_step::march_clipped(&grid, iso, inside, origin, dir, scene.render.steps, &clip);
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

    let distance = match (&exact.hit, &fixed.hit) {
        (Some(a), Some(f)) => Some((a.position - f.position).length()),
        _ => None,
    };
    let report = json!({
        "scene": args.scene.display().to_string(),
        "pixel": [px, py],
        "image": [scene.image.width, scene.image.height],
        "isovalue": iso,
        "inside": format!("{inside:?}").to_lowercase(),
        "ray": {"origin": v3(origin), "direction": v3(dir)},
        "box_span": exact.span.map(|(a, b)| json!([a, b])),
        "analytic": {
            "newton_steps": opts.newton_steps,
            "hit": exact.hit.as_ref().map(|h| json!({
                "t": h.t, "position": v3(h.position), "normal": v3(h.normal), "cell": h.cell,
                "local": v3(h.local),
            })),
            "cells_visited": exact.cells_visited,
            "crossings": exact.crossings,
            "inside_at_start": exact.inside_at_start,
            "cells": visits.iter().map(visit_json).collect::<Vec<_>>(),
        },
        "fixed_step": {
            "steps": scene.render.steps,
            "samples_taken": fixed.steps,
            "hit": fixed.hit.as_ref().map(|h| json!({
                "t": h.t, "position": v3(h.position), "normal": v3(h.normal), "cell": h.cell,
            })),
            "closest_sample_to_isovalue": fixed.margin,
        },
        "hit_distance": distance,
    });
    let mut report = report;
    if let Some(p) = crate::output::describe_placement(placement) {
        report["placement"] = json!(p);
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report).map_err(Failure::input)?);
        return Ok(0);
    }

    println!(
        "pixel ({px}, {py}) of {}x{}, isovalue {iso}, inside {inside:?}",
        scene.image.width, scene.image.height
    );
    println!("ray    origin {:.6}  direction {:.6}", origin, dir);
    match exact.span {
        Some((a, b)) => println!("box    t in [{a:.6}, {b:.6}]"),
        None => println!("box    the ray misses the grid box"),
    }
    println!();
    println!(
        "analytic (newton_steps = {}): {} crossing(s), {} cell(s) visited",
        opts.newton_steps, exact.crossings, exact.cells_visited
    );
    for v in &visits {
        let c = &v.corners;
        println!(
            "  cell {:?}  t [{:.6}, {:.6}]  corners v000 {:.5} v100 {:.5} v010 {:.5} v110 {:.5} v001 {:.5} v101 {:.5} v011 {:.5} v111 {:.5}",
            v.cell, v.t_in, v.t_out, c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]
        );
        let k = v.coefficients;
        println!("    g(u) = f - iso = {:.6e} + {:.6e} u + {:.6e} u^2 + {:.6e} u^3, u in [0,1] over the segment", k[0], k[1], k[2], k[3]);
        if !v.derivative_roots.is_empty() {
            println!("    g'(u) = 0 at u = {:?}", v.derivative_roots);
        }
        for r in &v.roots {
            println!(
                "    crossing #{}: u = {:.9} t = {:.9} ({}){}  bracket [{:.6}, {:.6}]  Newton iterates {:?}",
                r.crossing,
                r.u,
                r.t,
                if r.entering { "entering" } else { "leaving" },
                if r.exact { ", exactly on a split point" } else { "" },
                r.bracket.0,
                r.bracket.1,
                r.iterates
            );
        }
    }
    match &exact.hit {
        Some(h) => println!(
            "  hit: t = {:.9}  position {:.6}  normal {:.6}  cell {:?}",
            h.t, h.position, h.normal, h.cell
        ),
        None => println!("  no hit"),
    }
    println!();
    println!("fixed-step (steps = {}): {} sample(s) taken", scene.render.steps, fixed.steps);
    match &fixed.hit {
        Some(h) => println!(
            "  first crossing: t = {:.9}  position {:.6}  cell {:?}",
            h.t, h.position, h.cell
        ),
        None => println!(
            "  no crossing found (closest sample is {:.3e} from the isovalue)",
            fixed.margin
        ),
    }
    println!();
    match (&exact.hit, &fixed.hit, distance) {
        (Some(a), Some(f), Some(d)) => println!(
            "difference: |t_fixed - t_analytic| = {:.3e}, positions {d:.3e} apart",
            (f.t - a.t).abs()
        ),
        (Some(_), None, _) => {
            println!("difference: fixed-step MISSES a surface that the exact trace hits")
        }
        (None, Some(_), _) => {
            println!("difference: fixed-step reports a crossing the exact trace does not")
        }
        _ => println!("difference: both miss"),
    }
    Ok(0)
}
