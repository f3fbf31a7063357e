//! `isoview stats SCENE.toml`: what the field holds, to pick an isovalue. Dims, the source's
//! sample type, spacing, the world box, value range, mean, σ, percentiles and a text
//! histogram of the samples (at `--time`), and the scene's isovalue with how it was chosen.

use crate::vocab::echo_number;
use std::path::PathBuf;

use clap::Args;

use super::console::say;
use super::{load_scene, Failure};
use crate::field::stats::Stats;

#[derive(Args, Debug)]
pub struct StatsArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Override a scene key (as for `render`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Time t for fields that depend on it.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = super::number)]
    pub time: f64,
    /// Histogram bins.
    #[arg(long, allow_hyphen_values = true, default_value_t = 24)]
    pub bins: usize,
}

/// The percentiles printed.
pub const PERCENTILES: [f64; 7] = [1.0, 5.0, 25.0, 50.0, 75.0, 95.0, 99.0];

pub fn run(args: &StatsArgs) -> Result<i32, Failure> {
    super::finite("--time", args.time)?;
    if !(1..=200).contains(&args.bins) {
        return Err(Failure::input(format!("--bins {}: must be in 1..=200", args.bins)));
    }
    let scene = load_scene(&args.scene, &args.sets)?;
    let grid = scene.field.sample(args.time).map_err(Failure::input)?;
    let s = Stats::of(&grid.values);
    let f = &scene.field;
    let [nx, ny, nz] = grid.dims;
    let spacing = grid.spacing();
    say!("field       {}", f.describe())?;
    say!("dims        {nx} x {ny} x {nz} ({} points)", s.count)?;
    say!("dtype       {}", f.source.dtype())?;
    // Every number in its short form: a spacing of 1e-300 printed 302 characters.
    let n = echo_number::<f64>;
    say!("spacing     {} {} {}", n(spacing.x), n(spacing.y), n(spacing.z))?;
    let (lo, hi) = (grid.min, grid.max);
    if f.placement.is_identity() {
        let (lo, hi) = (lo.to_array().map(n), hi.to_array().map(n));
        say!("box         [{}] .. [{}]", lo.join(", "), hi.join(", "))?;
    } else {
        let a = f.placement.axes;
        say!(
            "box         [{}, {}, {}] .. [{}, {}, {}] in the grid's frame, axes x {:.6} y {:.6} z \
             {:.6} about [{}, {}, {}]",
            n(lo.x),
            n(lo.y),
            n(lo.z),
            n(hi.x),
            n(hi.y),
            n(hi.z),
            a.x_axis,
            a.y_axis,
            a.z_axis,
            n(f.placement.pivot.x),
            n(f.placement.pivot.y),
            n(f.placement.pivot.z)
        )?;
    }
    // Missing data (field.nan = "empty") is left out of every figure below.
    say!(
        "non-finite  {} sample(s) (NaN or inf: missing data, left out of the figures below)",
        s.missing
    )?;
    let iso = scene.surface.isovalue;
    if s.finite() == 0 {
        // No finite sample: no range, mean or percentile to print (they read 0 .. 0 and -0).
        say!("range       none: every sample is missing data")?;
        return match scene.surface.rule.describe(iso) {
            Some(how) => say!("isovalue    {how}"),
            None => say!("isovalue    {}", n(iso)),
        }
        .map(|_| 0);
    }
    say!("range       {} .. {}", echo_number(s.min), echo_number(s.max))?;
    say!("mean        {}", n(s.mean))?;
    say!("sigma       {}", n(s.sigma))?;
    let p: Vec<String> = PERCENTILES
        .iter()
        .filter_map(|&p| Some(format!("p{p}={}", echo_number(s.percentile(p)?))))
        .collect();
    say!("percentiles {}", p.join(" "))?;
    match scene.surface.rule.describe(iso) {
        Some(how) => say!("isovalue    {how}")?,
        // Every finite sample equal: no spread to measure the distance in (it read NaN or inf).
        None if s.sigma == 0.0 => {
            say!("isovalue    {} (sigma 0: the samples are all {})", n(iso), n(s.mean))?
        }
        None => {
            say!("isovalue    {} (sigma {:+.3} from the mean)", n(iso), (iso - s.mean) / s.sigma)?
        }
    }
    say!("histogram   ({} bins over the range)", args.bins)?;
    let counts = s.histogram(args.bins);
    let most = counts.iter().copied().max().unwrap_or(1).max(1);
    let width = (s.max - s.min) / args.bins as f64;
    for (b, &c) in counts.iter().enumerate() {
        let from = s.min + width * b as f64;
        let bar = "#".repeat((c * 50).div_ceil(most).min(50));
        let mark = if (from..from + width).contains(&iso) { " <- isovalue" } else { "" };
        say!("  {from:>14.6e} {c:>10} {bar}{mark}")?;
    }
    Ok(0)
}
