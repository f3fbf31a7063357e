//! `isoview probe SCENE --pixel X,Y [--json]`: what the ray through one pixel meets, from the f64
//! references: every cell the exact walk visits with its 8 corner values, the cubic along the
//! segment, its derivative roots, the roots found and their Newton iterates; where fixed-step
//! with the scene's `steps` finds (or misses) its first crossing; and how far apart the two are.
//! The tool for "why does this pixel look wrong".

use std::path::PathBuf;

use super::console::say;
use super::{Cli, Failure};
use crate::field::interpolant::Interpolant;
use crate::probe::PixelProbe;
use crate::reference::analytic::Polynomial;
use crate::scene::{self, Scene};

#[derive(clap::Args, Debug)]
pub struct ProbeArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Pixel column and row (row 0 at the top), e.g. --pixel 120,64.
    #[arg(
        long,
        allow_hyphen_values = true,
        value_name = "X,Y",
        required_unless_present = "slice",
        conflicts_with = "slice"
    )]
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
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = super::number)]
    pub time: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(_cli: &Cli, args: &ProbeArgs) -> Result<i32, Failure> {
    super::finite("--time", args.time)?;
    if let Some(s) = &args.slice {
        let segment = args.segment.as_deref();
        return super::slice::probe(&args.scene, &args.sets, args.time, s, segment, args.json);
    }
    let scene = scene::load(&args.scene, &args.sets).map_err(Failure::input)?;
    super::refuse_interpolation(&scene, crate::field::interpolant::Reader::Probe)?;
    let pixel = args.pixel.as_deref().ok_or_else(|| Failure::input("--pixel X,Y is missing"))?;
    let (px, py) = crate::probe::parse_pixel(pixel, scene.image.width, scene.image.height)
        .map_err(Failure::input)?;
    let grid = scene.field.sample(args.time).map_err(Failure::input)?;
    let name = args.scene.display().to_string();
    if !scene.surface.several() {
        let probe = PixelProbe::new(&scene, &grid, px, py);
        if args.json {
            let report = probe.json(&scene, &name);
            say!("{}", serde_json::to_string_pretty(&report).map_err(Failure::input)?)?;
        } else {
            print_probe(&scene, &probe, px, py)?;
        }
        return Ok(0);
    }
    // Several isovalues: each surface probed alone, then the one the render shows (the
    // nearest exact hit; ties: the lower surface).
    let probes: Vec<(Scene, PixelProbe)> = (0..scene.surface.count)
        .map(|k| {
            let one = scene.single_surface(k);
            let probe = PixelProbe::new(&one, &grid, px, py);
            (one, probe)
        })
        .collect();
    let mut shown: Option<(usize, f64)> = None;
    for (k, (_, p)) in probes.iter().enumerate() {
        if let Some(h) = &p.exact.hit {
            if shown.map_or(true, |(_, t)| h.t < t) {
                shown = Some((k, h.t));
            }
        }
    }
    if args.json {
        let surfaces: Vec<serde_json::Value> =
            probes.iter().map(|(one, p)| p.json(one, &name)).collect();
        let report = serde_json::json!({
            "isovalues": scene.surface.isovalues(),
            "shown_surface": shown.map(|(k, _)| k),
            "surfaces": surfaces,
        });
        say!("{}", serde_json::to_string_pretty(&report).map_err(Failure::input)?)?;
        return Ok(0);
    }
    for (k, (one, p)) in probes.iter().enumerate() {
        say!("=== surface {k} of {} (isovalue {}) ===", scene.surface.count, one.surface.isovalue)?;
        print_probe(one, p, px, py)?;
        say!()?;
    }
    match shown {
        Some((k, t)) => say!("shown: surface {k} (the nearest exact hit, t = {t:.9})")?,
        None => say!("shown: nothing (no surface is hit)")?,
    }
    Ok(0)
}

/// The text report of one surface's probe.
fn print_probe(scene: &Scene, probe: &PixelProbe, px: u32, py: u32) -> Result<(), Failure> {
    let PixelProbe { origin, dir, options: opts, exact, visits, voxels, fixed, .. } = probe;
    let distance = probe.hit_distance();
    let (iso, inside) = (scene.surface.isovalue, scene.surface.inside);

    say!(
        "pixel ({px}, {py}) of {}x{}, isovalue {iso}, inside {inside:?}",
        scene.image.width,
        scene.image.height
    )?;
    say!("ray    origin {:.6}  direction {:.6}", origin, dir)?;
    match exact.span {
        Some((a, b)) => say!("box    t in [{a:.6}, {b:.6}]")?,
        None => say!("box    the ray misses the grid box")?,
    }
    say!()?;
    let interp = probe.interpolation;
    if interp == Interpolant::Nearest {
        say!(
            "analytic, nearest's voxel walk: {} crossing(s), {} voxel(s) visited",
            exact.crossings,
            exact.cells_visited
        )?;
        for v in voxels {
            let state = match v.inside {
                Some(true) => "inside",
                Some(false) => "outside",
                None => "missing: no surface on its faces",
            };
            say!(
                "  voxel {:?}  t [{:.6}, {:.6}]  value {:.6}  {state}",
                v.voxel,
                v.t_in,
                v.t_out,
                v.value
            )?;
        }
    } else {
        say!(
            "analytic ({}, newton_steps = {}): {} crossing(s), {} cell(s) visited",
            interp.name(),
            opts.newton_steps,
            exact.crossings,
            exact.cells_visited
        )?;
    }
    for v in visits {
        let c = &v.samples;
        if v.missing {
            say!("  {}  t [{:.6}, {:.6}]", crate::probe::missing_note(v), v.t_in, v.t_out)?;
            continue;
        }
        match &v.coefficients {
            Polynomial::Monomial(k) => {
                say!(
                    "  cell {:?}  t [{:.6}, {:.6}]  corners v000 {:.5} v100 {:.5} v010 {:.5} v110 {:.5} v001 {:.5} v101 {:.5} v011 {:.5} v111 {:.5}",
                    v.cell, v.t_in, v.t_out, c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]
                )?;
                say!("    g(u) = f - iso = {:.6e} + {:.6e} u + {:.6e} u^2 + {:.6e} u^3, u in [0,1] over the segment", k[0], k[1], k[2], k[3])?;
            }
            Polynomial::Bernstein(b) => {
                let (lo, hi) = c
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
                say!(
                    "  cell {:?}  t [{:.6}, {:.6}]  64 samples (offsets -1..2, --json lists them) in [{lo:.5}, {hi:.5}]",
                    v.cell, v.t_in, v.t_out
                )?;
                let shown: Vec<String> = b.iter().map(|x| format!("{x:.6e}")).collect();
                say!(
                    "    g(u) = f - iso, degree {} in Bernstein form on [0,1]: b = [{}]",
                    b.len() - 1,
                    shown.join(", ")
                )?;
                for l in &v.leaves {
                    say!(
                        "    leaf u [{:.6}, {:.6}]: {} sign change(s){}",
                        l.u.0,
                        l.u.1,
                        l.variations,
                        if l.resolved { "" } else { " (unresolved: depth or node cap)" }
                    )?;
                }
            }
        }
        if !v.derivative_roots.is_empty() {
            say!("    g'(u) = 0 at u = {:?}", v.derivative_roots)?;
        }
        for r in &v.roots {
            say!(
                "    crossing #{}: u = {:.9} t = {:.9} ({}){}  bracket [{:.6}, {:.6}]  Newton iterates {:?}",
                r.crossing,
                r.u,
                r.t,
                if r.entering { "entering" } else { "leaving" },
                if r.exact { ", exactly on a split point" } else { "" },
                r.bracket.0,
                r.bracket.1,
                r.iterates
            )?;
        }
    }
    match &exact.hit {
        Some(h) => say!(
            "  hit: t = {:.9}  position {:.6}  normal {:.6}  cell {:?}",
            h.t,
            h.position,
            h.normal,
            h.cell
        )?,
        None => say!("  no hit")?,
    }
    say!()?;
    say!("fixed-step (steps = {}): {} sample(s) taken", scene.render.steps, fixed.steps)?;
    match &fixed.hit {
        Some(h) => {
            say!("  first crossing: t = {:.9}  position {:.6}  cell {:?}", h.t, h.position, h.cell)?
        }
        None => say!("  {}", crate::probe::march_miss_note(fixed))?,
    }
    say!()?;
    match (&exact.hit, &fixed.hit, distance) {
        (Some(a), Some(f), Some(d)) => say!(
            "difference: |t_fixed - t_analytic| = {:.3e}, positions {d:.3e} apart",
            (f.t - a.t).abs()
        )?,
        (Some(_), None, _) => {
            say!("difference: fixed-step MISSES a surface that the exact trace hits")?
        }
        (None, Some(_), _) => {
            say!("difference: fixed-step reports a crossing the exact trace does not")?
        }
        _ => say!("difference: both miss")?,
    }
    Ok(())
}
