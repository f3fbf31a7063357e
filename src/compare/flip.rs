//! The perceptual FLIP figure for the beauty, through the `nv-flip` crate (bindings to
//! NVIDIA's reference implementation; LDR-FLIP only).
//!
//! FLIP compares sRGB-encoded images in [0, 1], so the linear beauty is first clamped,
//! sRGB-encoded and quantised to 8 bits exactly as the PNG preview is
//! ([`crate::output::png::to_srgb8`]); alpha is ignored (isoview's colour is already over its
//! background). The statistics are those of the per-pixel error map, in [0, 1].

use crate::output::exr::ExrImage;
use crate::output::png::to_srgb8;

/// Pixels per degree of visual angle (FLIP's default: a 0.7 m wide 4K monitor seen from
/// 0.7 m).
pub const PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// Summary of a FLIP error map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlipStats {
    pub mean: f32,
    /// Nearest-rank percentiles of the per-pixel error.
    pub p50: f32,
    pub p95: f32,
    pub p99: f32,
    pub max: f32,
    pub pixels_per_degree: f32,
}

/// The beauty of `image` as 8-bit sRGB RGB, or why it has none.
fn srgb8(image: &ExrImage) -> Result<Vec<u8>, String> {
    let channel = |name: &str| {
        image
            .channel(name)
            .map(|c| c.values.as_slice())
            .ok_or_else(|| format!("not computed: {} has no {name} channel", image.path.display()))
    };
    let (r, g, b) = (channel("R")?, channel("G")?, channel("B")?);
    Ok((0..image.width * image.height)
        .flat_map(|i| {
            let [r, g, b, _] = to_srgb8([r[i], g[i], b[i], 1.0]);
            [r, g, b]
        })
        .collect())
}

/// FLIP of B's beauty against A's (the reference): statistics and the per-pixel error map
/// (row-major). `Err` says why it could not be computed (no R, G, B; sizes differ).
pub fn flip_beauty(a: &ExrImage, b: &ExrImage) -> Result<(FlipStats, Vec<f32>), String> {
    if (a.width, a.height) != (b.width, b.height) || a.width == 0 || a.height == 0 {
        return Err("not computed: the images differ in size".into());
    }
    let (w, h) = (
        u32::try_from(a.width).map_err(|_| "image too wide")?,
        u32::try_from(a.height).map_err(|_| "image too tall")?,
    );
    let reference = nv_flip::FlipImageRgb8::with_data(w, h, &srgb8(a)?);
    let test = nv_flip::FlipImageRgb8::with_data(w, h, &srgb8(b)?);
    let map = nv_flip::flip(reference, test, PIXELS_PER_DEGREE).to_vec();
    let mean = (map.iter().map(|&v| f64::from(v)).sum::<f64>() / map.len() as f64) as f32;
    let mut sorted = map.clone();
    sorted.sort_by(f32::total_cmp);
    let rank = |p: f64| {
        let k = ((p * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
        sorted[k - 1]
    };
    let stats = FlipStats {
        mean,
        p50: rank(0.50),
        p95: rank(0.95),
        p99: rank(0.99),
        max: sorted[sorted.len() - 1],
        pixels_per_degree: PIXELS_PER_DEGREE,
    };
    Ok((stats, map))
}
