//! The files `compare` can write: a difference EXR and a heat-map PNG.
//!
//! `--diff DIFF.exr` (one part, 32-bit float, ZIP; written like isoview's renders):
//!
//! | channel | value |
//! | --- | --- |
//! | `diff.<name>` | B − A for every compared channel; 0 where the values are equal (also inf = inf, NaN = NaN); ±inf or NaN where a non-finite value met a different one |
//! | `fail` | 1 where the pixel fails, else 0 (the fail mask) |
//! | `forgiven` | 1 where the shift window forgave a failing pixel (only with the shift window) |
//! | `ratio` | the largest difference / fail tolerance over the channels (inf for non-finite mismatches and for any difference under a zero tolerance) |
//! | `flip` | FLIP error of the beauty, when computed |
//!
//! Header attributes: `isoview/compare/a`, `isoview/compare/b`, `isoview/compare/verdict`
//! (the verdict line) and `isoview/version`.
//!
//! `--png DIFF.png` (RGBA8): black where every channel is equal; pixels that differ within the
//! fail thresholds on the magma colour map (dark purple to orange) by `log10` of the ratio,
//! from 1e-6 of the threshold to the threshold; failing pixels pale yellow (the top of magma);
//! forgiven pixels cyan.

use std::path::Path;

use super::{PixelState, Report};
use crate::output::exr::{write_channels, ExrImage};
use crate::output::png::write_rgba8;
use crate::output::OutputError;

/// B − A under the NaN/inf equality rules.
fn signed_difference(a: f32, b: f32) -> f32 {
    match super::difference(a, b) {
        Some(0.0) => 0.0,
        _ => b - a,
    }
}

/// Writes the difference EXR described in the module docs.
pub fn write_diff_exr(
    path: &Path,
    a: &ExrImage,
    b: &ExrImage,
    report: &Report,
) -> Result<(), OutputError> {
    let mut channels = Vec::new();
    for s in &report.channels {
        let (Some(ca), Some(cb)) = (a.channel(&s.name), b.channel(&s.name)) else {
            return Err(OutputError::invalid(
                path,
                format!("channel {:?} is not in both images of the report", s.name),
            ));
        };
        let d = ca.values.iter().zip(&cb.values).map(|(&x, &y)| signed_difference(x, y)).collect();
        channels.push((format!("diff.{}", s.name), d));
    }
    let mask = |want: PixelState| {
        report.pixels.iter().map(|&p| if p == want { 1.0 } else { 0.0 }).collect::<Vec<f32>>()
    };
    channels.push(("fail".to_string(), mask(PixelState::Fail)));
    if report.thresholds.shift {
        channels.push(("forgiven".to_string(), mask(PixelState::Forgiven)));
    }
    channels.push(("ratio".to_string(), report.ratio.clone()));
    if let Some(flip) = &report.flip_map {
        channels.push(("flip".to_string(), flip.clone()));
    }
    let attributes = [
        ("isoview/compare/a".to_string(), report.a.display().to_string()),
        ("isoview/compare/b".to_string(), report.b.display().to_string()),
        ("isoview/compare/verdict".to_string(), report.verdict_line()),
        ("isoview/version".to_string(), crate::VERSION.to_string()),
    ];
    write_channels(path, report.width, report.height, channels, &attributes)
}

/// The heat map described in the module docs, as RGBA8 pixels.
pub fn heat_map_rgba8(report: &Report) -> Vec<u8> {
    report
        .pixels
        .iter()
        .zip(&report.ratio)
        .flat_map(|(&state, &r)| match state {
            PixelState::Same => [0, 0, 0, 255],
            PixelState::Fail => {
                let c = colorous::MAGMA.eval_continuous(1.0);
                [c.r, c.g, c.b, 255]
            }
            PixelState::Forgiven => [0, 200, 255, 255],
            PixelState::Close | PixelState::Warn => {
                let t = if r > 0.0 {
                    ((f64::from(r).log10() + 6.0) / 6.0).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let c = colorous::MAGMA.eval_continuous(0.15 + 0.6 * t);
                [c.r, c.g, c.b, 255]
            }
        })
        .collect()
}

/// Writes the heat map PNG, atomically.
pub fn write_heat_map_png(path: &Path, report: &Report) -> Result<(), OutputError> {
    let (w, h) = (
        u32::try_from(report.width).map_err(|_| OutputError::invalid(path, "image too wide"))?,
        u32::try_from(report.height).map_err(|_| OutputError::invalid(path, "image too tall"))?,
    );
    write_rgba8(path, w, h, &heat_map_rgba8(report))
}
