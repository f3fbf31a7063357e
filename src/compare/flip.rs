//! The perceptual FLIP figure for the beauty, through the `nv-flip` crate (bindings to
//! NVIDIA's reference implementation; LDR-FLIP only), computed band by band in
//! [`super::stream`].
//!
//! FLIP compares sRGB-encoded images in [0, 1], so the linear beauty is first clamped,
//! sRGB-encoded and quantised to 8 bits exactly as the PNG preview is
//! ([`crate::output::png::to_srgb8`]); alpha is ignored (isoview's colour is already over its
//! background). The statistics are those of the per-pixel error map, in [0, 1].

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
