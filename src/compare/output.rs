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

use super::stream::{diff_plane, Outputs, Writers};
use super::{PixelMaps, PixelState, Report};
use crate::output::exr::ExrImage;
use crate::output::OutputError;

/// B − A under the NaN/inf equality rules.
pub(super) fn signed_difference(a: f32, b: f32) -> f32 {
    match super::difference(a, b) {
        Some(0.0) => 0.0,
        _ => b - a,
    }
}

/// Writes the difference EXR described in the module docs from a whole-image report, through
/// the band-by-band comparison's writers (all its rows at once).
pub fn write_diff_exr(
    path: &Path,
    a: &ExrImage,
    b: &ExrImage,
    report: &Report,
) -> Result<(), OutputError> {
    let maps = report_maps(path, report)?;
    let mut diffs = Vec::new();
    for s in &report.channels {
        let (Some(ca), Some(cb)) = (a.channel(&s.name), b.channel(&s.name)) else {
            return Err(OutputError::invalid(
                path,
                format!("channel {:?} is not in both images of the report", s.name),
            ));
        };
        diffs.push(diff_plane(&ca.values, &cb.values));
    }
    write_maps(report, maps, Outputs { diff: Some(path), png: None }, diffs)
}

/// Writes `outputs` from a whole-image report's maps (one band).
fn write_maps(
    report: &Report,
    maps: &PixelMaps,
    outputs: Outputs<'_>,
    diffs: Vec<Vec<f32>>,
) -> Result<(), OutputError> {
    let mut writers = Writers::create(report, outputs);
    writers.push(|| diffs, &maps.pixels, &maps.ratio, maps.flip.as_deref());
    writers.finish().map_or(Ok(()), Err)
}

/// The header attributes of the difference EXR.
pub(super) fn diff_attributes(report: &Report) -> [(String, String); 4] {
    [
        ("isoview/compare/a".to_string(), report.a.display().to_string()),
        ("isoview/compare/b".to_string(), report.b.display().to_string()),
        ("isoview/compare/verdict".to_string(), report.verdict_line()),
        ("isoview/version".to_string(), crate::VERSION.to_string()),
    ]
}

/// The per-pixel maps of a whole-image report.
fn report_maps<'r>(path: &Path, report: &'r Report) -> Result<&'r PixelMaps, OutputError> {
    report.maps.as_ref().ok_or_else(|| {
        OutputError::invalid(
            path,
            "internal: a band-by-band report keeps no per-pixel maps (its outputs are written \
             during the comparison)",
        )
    })
}

/// The heat-map colour of one pixel from its state and ratio.
pub(super) fn heat_rgba8(state: PixelState, ratio: f32) -> [u8; 4] {
    match state {
        PixelState::Same => [0, 0, 0, 255],
        PixelState::Fail => {
            let c = colorous::MAGMA.eval_continuous(1.0);
            [c.r, c.g, c.b, 255]
        }
        PixelState::Forgiven => [0, 200, 255, 255],
        PixelState::Close | PixelState::Warn => {
            let t = if ratio > 0.0 {
                ((f64::from(ratio).log10() + 6.0) / 6.0).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let c = colorous::MAGMA.eval_continuous(0.15 + 0.6 * t);
            [c.r, c.g, c.b, 255]
        }
    }
}

/// Writes the heat map PNG of a whole-image report, atomically, through the band-by-band
/// comparison's writers (all its rows at once).
pub fn write_heat_map_png(path: &Path, report: &Report) -> Result<(), OutputError> {
    let maps = report_maps(path, report)?;
    write_maps(report, maps, Outputs { diff: None, png: Some(path) }, Vec::new())
}
