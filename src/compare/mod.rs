//! Comparison of float EXR images (`isoview compare A.exr B.exr`): A is the reference, B the
//! image under test.
//!
//! # What is compared
//!
//! Both images must have the same size and the same channel names (or contain every channel
//! of [`Thresholds::only`]; with [`Thresholds::new_channels`], B may have channels A lacks,
//! reported and not compared). Each channel is compared value by value:
//!
//! - NaN equals NaN only; +inf equals +inf, -inf equals -inf. A non-finite value against
//!   anything it does not equal (NaN vs 1, +inf vs 3.5) is a *non-finite mismatch*: it is over
//!   every threshold and counted, but left out of the statistics (max, mean, RMSE, p99).
//! - Otherwise `d = |a - b|` (in f64), and the value is *over* a threshold `T` when
//!   `d > max(T, R * max(|a|, |b|))`, with `R` the relative threshold (`--fail-relative`,
//!   default 0: absolute only).
//!
//! Thresholds come per channel class ([`ChannelClass`]): colour `R G B A`, depth `Z`, normal
//! `N.*`, position `P.*`, integer-valued `steps`, `cell.*`, `crossings` and any UINT channel,
//! and other. Defaults ([`Thresholds::default`]): fail 1e-4 absolute for every float class,
//! 0 (exact) for integer channels; warn 1e-6; fail-percent and warn-percent 0.
//!
//! # Verdict (in the spirit of OpenImageIO's idiff)
//!
//! A pixel *fails* when any channel is over its fail threshold, and *warns* when any channel is
//! over its warn threshold (never above the class's fail threshold). The comparison:
//!
//! - **fails** when the failing pixels are more than `fail_percent` % of all pixels, when any
//!   pixel differs by more than `hard_fail` (if set; non-finite mismatches count), or when
//!   the FLIP mean is over `flip_fail` (if set);
//! - otherwise **warns** when the warning pixels are more than `warn_percent` %;
//! - otherwise **passes** ("identical" when every value is equal).
//!
//! # Coverage and the shift window
//!
//! Coverage is a hit: finite `Z` when both images have `Z`, else `A > 0`. Pixels covered in
//! only one image are counted. With [`Thresholds::shift`] a failing pixel is *forgiven*
//! (counted separately, not failing, still warning) when the silhouette merely moved by one
//! pixel around it:
//!
//! ```text
//!   A  . . # #      B  . # # #     pixel p = the middle column: a hit in B, a miss in A.
//!      . . # #         . # # #     Forgiven, because in the 3x3 window around p
//!      . . # #         . # # #     both A and B have hits *and* misses.
//! ```
//!
//! (a) its coverage differs and, in the 3x3 window around it, each image has both a hit and a
//! miss; or (b) every channel of A at p matches B at some pixel of the window, and every
//! channel of B at p matches A at some pixel of the window (Filament's `shiftRadius`).
//!
//! # Perceptual figure
//!
//! When both images have `R`, `G`, `B`, NVIDIA's FLIP (LDR, via the `nv-flip` crate) is
//! computed on the beauty clamped to [0, 1], sRGB-encoded and quantised to 8 bits, at 67
//! pixels per degree: mean, p50, p95, p99 and max of the per-pixel error map. It is reported,
//! and gates the verdict only when `flip_fail` is set.

mod flip;
mod output;
mod rows;
mod select;
mod stream;

pub use flip::{FlipStats, PIXELS_PER_DEGREE};
pub use output::{write_diff_exr, write_heat_map_png};
pub use stream::{
    band_rows, compare_files, compare_files_in_bands, flip_halo, Outputs, BAND_BYTES,
    MAX_IMAGE_BYTES, PERCENTILE_BATCH,
};

use std::fmt;
use std::path::{Path, PathBuf};

use crate::frame::Channel;
pub use crate::frame::ChannelClass;
use crate::output::exr::{ExrImage, SampleKind};
use crate::output::OutputError;

/// Default absolute fail threshold of the float channel classes.
pub const DEFAULT_FAIL: f64 = 1e-4;
/// Default warn threshold.
pub const DEFAULT_WARN: f64 = 1e-6;

/// Why two images could not be compared.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("size mismatch: {} is {}x{}, {} is {}x{}", a.display(), a_size.0, a_size.1, b.display(), b_size.0, b_size.1)]
    SizeMismatch { a: PathBuf, a_size: (usize, usize), b: PathBuf, b_size: (usize, usize) },
    #[error("channel mismatch: only in {}: {}; only in {}: {}", a.display(), list_or_none(only_a), b.display(), list_or_none(only_b))]
    ChannelMismatch { a: PathBuf, only_a: Vec<String>, b: PathBuf, only_b: Vec<String> },
    #[error("{}: no channel {channel:?} (it has {})", path.display(), list_or_none(available))]
    MissingChannel { path: PathBuf, channel: String, available: Vec<String> },
    /// A streamed comparison would hold more than [`MAX_IMAGE_BYTES`] of one image at once.
    #[error("{}: comparing {channels} channels of rows {width} pixels wide needs {mib} MiB of it at once, over compare's limit of {} MiB an image; compare fewer channels at once (--channels)", path.display(), MAX_IMAGE_BYTES >> 20)]
    TooLarge { path: PathBuf, channels: usize, width: usize, mib: u64 },
    #[error("{0}")]
    Output(#[from] OutputError),
}

/// Names for a one-line message: at most 12, then how many more.
fn list_or_none(names: &[String]) -> String {
    const SHOWN: usize = 12;
    match names.len() {
        0 => "(none)".into(),
        n if n <= SHOWN => names.join(", "),
        n => format!("{} and {} more", names[..SHOWN].join(", "), n - SHOWN),
    }
}

impl ChannelClass {
    /// The class of a channel from its full name and its sample type in the file: a UINT
    /// channel is integer; a channel isoview writes has its class from the channel table
    /// ([`Channel`]); any other name is classed by its base (after the last `.`) and layer.
    pub fn of(name: &str, kind: SampleKind) -> ChannelClass {
        if kind == SampleKind::U32 {
            return ChannelClass::Integer;
        }
        match Channel::from_name(name) {
            Some(c) => c.class(),
            None => class_by_name(name),
        }
    }
}

/// The class a channel name suggests (split at the last `.` into layer and base), for EXRs
/// from other writers.
fn class_by_name(name: &str) -> ChannelClass {
    let (layer, base) = match name.rfind('.') {
        Some(i) => (&name[..i], &name[i + 1..]),
        None => ("", name),
    };
    let group = layer.rsplit('.').next().unwrap_or("");
    match (group, base) {
        (_, "steps" | "crossings" | "iso_index") | ("cell", _) => ChannelClass::Integer,
        ("N" | "normal" | "Normal", _) => ChannelClass::Normal,
        ("P" | "position" | "Position", _) => ChannelClass::Position,
        (_, "Z" | "ZBack") => ChannelClass::Depth,
        (_, "R" | "G" | "B" | "A") => ChannelClass::Colour,
        _ => ChannelClass::Other,
    }
}

/// What counts as a difference (see the module docs for the rules).
#[derive(Clone, Debug, PartialEq)]
pub struct Thresholds {
    /// Absolute fail threshold for the float classes.
    pub fail: f64,
    /// Per-class overrides of the fail threshold (the last one given for a class wins).
    /// The integer class is 0 unless overridden here.
    pub fail_class: Vec<(ChannelClass, f64)>,
    /// Relative fail threshold `R`: a value is over `T` only when `d > max(T, R * max(|a|, |b|))`.
    pub fail_relative: f64,
    /// The comparison fails when more than this percentage of pixels fail.
    pub fail_percent: f64,
    /// Any pixel with a difference over this fails the comparison, whatever the percentage.
    pub hard_fail: Option<f64>,
    /// Absolute warn threshold (capped at each class's fail threshold).
    pub warn: f64,
    /// The comparison warns when more than this percentage of pixels are over `warn`.
    pub warn_percent: f64,
    /// Forgive failing pixels where a silhouette moved by one pixel.
    pub shift: bool,
    /// Compute the FLIP figure for the beauty (when both images have R, G, B).
    pub flip: bool,
    /// Fail when the FLIP mean is over this (implies `flip`).
    pub flip_fail: Option<f64>,
    /// Compare only these channels (each must be in both images); `None`: all, and the
    /// channel sets must be equal (but see `new_channels`).
    pub only: Option<Vec<String>>,
    /// Accept channels that only B (the image under test) has: they are listed in
    /// [`Report::new_channels`] and not compared, and the channels both have are. A channel
    /// only A (the reference) has is still a mismatch. For goldens made before a channel was
    /// added; `compare --new-channels`.
    pub new_channels: bool,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            fail: DEFAULT_FAIL,
            fail_class: Vec::new(),
            fail_relative: 0.0,
            fail_percent: 0.0,
            hard_fail: None,
            warn: DEFAULT_WARN,
            warn_percent: 0.0,
            shift: false,
            flip: true,
            flip_fail: None,
            only: None,
            new_channels: false,
        }
    }
}

impl Thresholds {
    /// The absolute fail threshold of a class.
    pub fn fail_for(&self, class: ChannelClass) -> f64 {
        let base = match class {
            ChannelClass::Integer => 0.0,
            _ => self.fail,
        };
        self.fail_class.iter().rev().find(|(c, _)| *c == class).map_or(base, |(_, t)| *t)
    }

    /// The absolute warn threshold of a class.
    pub fn warn_for(&self, class: ChannelClass) -> f64 {
        self.warn.min(self.fail_for(class))
    }
}

/// Statistics of one channel.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelStats {
    pub name: String,
    pub class: ChannelClass,
    /// The absolute fail threshold applied.
    pub fail: f64,
    /// Largest `|a - b|` over pairs of finite values, and where (x, y) it is.
    pub max_abs: f64,
    pub max_at: Option<(usize, usize)>,
    /// Mean and root mean square of `|a - b|` over pairs of finite values.
    pub mean_abs: f64,
    pub rmse: f64,
    /// 99th percentile (nearest rank) of `|a - b| / max(|a|, |b|)` over finite pairs (0 for 0/0).
    pub rel_p99: f64,
    /// Pixels over the fail threshold (non-finite mismatches included).
    pub over_fail: usize,
    /// Pixels where a non-finite value met a value it does not equal.
    pub nonfinite: usize,
    /// Every value pair equal (NaN = NaN, inf = inf).
    pub identical: bool,
}

/// Pixels covered (hit) in one image only.
#[derive(Clone, Debug, PartialEq)]
pub struct Coverage {
    /// The channel coverage was read from (`Z` or `A`).
    pub channel: String,
    pub only_a: usize,
    pub only_b: usize,
}

/// The outcome of a comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Every value equal.
    Identical,
    /// Within the thresholds.
    Pass,
    /// Within the fail thresholds, but more pixels over the warn threshold than allowed.
    Warn,
    /// Over the thresholds.
    Fail,
}

impl Verdict {
    /// The exit status of `isoview compare`: 1 for a failure, else 0.
    pub fn exit_code(self) -> i32 {
        match self {
            Verdict::Fail => 1,
            _ => 0,
        }
    }
}

/// State of one pixel, for the diff outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelState {
    /// Every channel equal.
    Same,
    /// Different, within the warn thresholds.
    Close,
    /// Over a warn threshold, within the fail thresholds.
    Warn,
    /// Over a fail threshold, forgiven by the shift window.
    Forgiven,
    /// Over a fail threshold.
    Fail,
}

/// Everything a comparison found.
#[derive(Clone, Debug)]
pub struct Report {
    pub a: PathBuf,
    pub b: PathBuf,
    pub width: usize,
    pub height: usize,
    pub thresholds: Thresholds,
    /// One entry per compared channel, in A's order.
    pub channels: Vec<ChannelStats>,
    /// Channels only B has, not compared ([`Thresholds::new_channels`]); empty otherwise.
    pub new_channels: Vec<String>,
    /// Coverage mismatches, where coverage could be determined.
    pub coverage: Option<Coverage>,
    pub failing_pixels: usize,
    pub forgiven_pixels: usize,
    pub warning_pixels: usize,
    /// Pixels over the hard-fail threshold (0 when it is not set).
    pub hard_failing_pixels: usize,
    pub flip: Option<FlipStats>,
    /// Why FLIP was not computed, when it was asked for and could not be.
    pub flip_note: Option<String>,
    pub verdict: Verdict,
    /// The per-pixel results, from the whole-image [`compare`] (one band); `None` from the
    /// band-by-band [`compare_files`], which writes its outputs as the bands go by instead.
    pub maps: Option<PixelMaps>,
}

/// Per-pixel results of a whole-image comparison (what the diff outputs are made of).
#[derive(Clone, Debug)]
pub struct PixelMaps {
    /// Per pixel, row-major.
    pub pixels: Vec<PixelState>,
    /// Per pixel: the largest `d / tolerance` over the channels (inf for non-finite mismatches
    /// and for any difference where the tolerance is 0).
    pub ratio: Vec<f32>,
    /// The FLIP error map, when computed.
    pub flip: Option<Vec<f32>>,
}

impl Report {
    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width * self.height
    }

    fn percent(&self, n: usize) -> f64 {
        100.0 * n as f64 / self.pixel_count().max(1) as f64
    }

    /// The one-line verdict printed under the table.
    pub fn verdict_line(&self) -> String {
        let t = &self.thresholds;
        let failing = format!(
            "{} of {} pixels ({}) over the fail thresholds, limit {}%",
            self.failing_pixels,
            self.pixel_count(),
            pct(self.percent(self.failing_pixels)),
            t.fail_percent
        );
        match self.verdict {
            Verdict::Identical => "PASS: identical".into(),
            Verdict::Pass => format!("PASS: {failing}"),
            Verdict::Warn => format!(
                "WARN: {} pixels ({}) over the warn threshold, limit {}%; {failing}",
                self.warning_pixels,
                pct(self.percent(self.warning_pixels)),
                t.warn_percent
            ),
            Verdict::Fail => {
                let mut why = vec![failing];
                if self.hard_failing_pixels > 0 {
                    why.push(format!(
                        "{} pixels over the hard-fail threshold {}",
                        self.hard_failing_pixels,
                        t.hard_fail.unwrap_or(f64::INFINITY)
                    ));
                }
                if let (Some(limit), Some(f)) = (t.flip_fail, &self.flip) {
                    if f64::from(f.mean) > limit {
                        why.push(format!("FLIP mean {:.4} over {limit}", f.mean));
                    }
                }
                format!("FAIL: {}", why.join("; "))
            }
        }
    }
}

/// `12.5%` with few digits.
fn pct(p: f64) -> String {
    if p == 0.0 {
        "0%".into()
    } else if p < 0.01 {
        format!("{p:.2e}%")
    } else {
        format!("{p:.2}%")
    }
}

/// A statistic in the table: `0` for zero, else three significant digits.
fn num(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else {
        format!("{x:.3e}")
    }
}

impl fmt::Display for Report {
    /// The per-channel table, coverage, shift, FLIP, and the verdict line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "A: {}\nB: {}\n{}x{}, {} channels compared",
            self.a.display(),
            self.b.display(),
            self.width,
            self.height,
            self.channels.len()
        )?;
        let w = self.channels.iter().map(|c| c.name.len()).max().unwrap_or(0).max(7);
        writeln!(
            f,
            "{:<w$}  {:<8}  {:>9}  {:>9}  {:>11}  {:>9}  {:>9}  {:>9}  {:>9}  {:>9}",
            "channel",
            "class",
            "fail at",
            "max abs",
            "at x,y",
            "mean abs",
            "RMSE",
            "rel p99",
            "over",
            "nonfinite"
        )?;
        for c in &self.channels {
            let at = c
                .max_at
                .filter(|_| c.max_abs > 0.0)
                .map_or("-".to_string(), |(x, y)| format!("{x},{y}"));
            writeln!(
                f,
                "{:<w$}  {:<8}  {:>9}  {:>9}  {:>11}  {:>9}  {:>9}  {:>9}  {:>9}  {:>9}",
                c.name,
                c.class.name(),
                num(c.fail),
                num(c.max_abs),
                at,
                num(c.mean_abs),
                num(c.rmse),
                num(c.rel_p99),
                c.over_fail,
                c.nonfinite
            )?;
        }
        if !self.new_channels.is_empty() {
            writeln!(
                f,
                "note: not in A, not compared (new channels): {}",
                self.new_channels.join(", ")
            )?;
        }
        if let Some(cov) = &self.coverage {
            writeln!(
                f,
                "coverage ({}): {} pixels hit only in A, {} only in B",
                cov.channel, cov.only_a, cov.only_b
            )?;
        }
        if self.thresholds.shift {
            writeln!(
                f,
                "shift window: {} failing pixels forgiven (one-pixel silhouette shift)",
                self.forgiven_pixels
            )?;
        }
        match (&self.flip, &self.flip_note) {
            (Some(s), _) => writeln!(
                f,
                "FLIP (R,G,B as sRGB8, {} ppd): mean {:.4}  p50 {:.4}  p95 {:.4}  p99 {:.4}  max {:.4}",
                s.pixels_per_degree, s.mean, s.p50, s.p95, s.p99, s.max
            )?,
            (None, Some(note)) => writeln!(f, "FLIP: {note}")?,
            (None, None) => {}
        }
        writeln!(f, "{}", self.verdict_line())
    }
}

/// Equality of values under the NaN/inf rules, or `None` for a non-finite mismatch;
/// `Some(d)` is `|a - b|` for finite pairs and 0 for equal non-finite pairs.
fn difference(a: f32, b: f32) -> Option<f64> {
    if a.is_nan() || b.is_nan() {
        return (a.is_nan() && b.is_nan()).then_some(0.0);
    }
    if a.is_infinite() || b.is_infinite() {
        return (a == b).then_some(0.0);
    }
    Some((f64::from(a) - f64::from(b)).abs())
}

/// Whether `a` and `b` are within `abs` (or `rel` relatively) of each other.
fn within(a: f32, b: f32, abs: f64, rel: f64) -> bool {
    match difference(a, b) {
        None => false,
        Some(d) => d <= tolerance(a, b, abs, rel),
    }
}

fn tolerance(a: f32, b: f32, abs: f64, rel: f64) -> f64 {
    abs.max(rel * f64::from(a.abs().max(b.abs())))
}

/// The channels to compare (names present in both: all of A's when the sets are equal), and
/// the channels only B has when [`Thresholds::new_channels`] accepts them, from each image's
/// path and channel names (in file order).
fn select_names(
    a: (&Path, &[String]),
    b: (&Path, &[String]),
    t: &Thresholds,
) -> Result<(Vec<String>, Vec<String>), CompareError> {
    let has = |names: &[String], n: &String| names.contains(n);
    match &t.only {
        Some(only) => {
            for (path, names) in [a, b] {
                if let Some(missing) = only.iter().find(|n| !has(names, n)) {
                    return Err(CompareError::MissingChannel {
                        path: path.to_path_buf(),
                        channel: missing.clone(),
                        available: names.to_vec(),
                    });
                }
            }
            let mut v = only.clone();
            v.dedup();
            Ok((v, Vec::new()))
        }
        None => {
            let only_a: Vec<String> = a.1.iter().filter(|n| !has(b.1, n)).cloned().collect();
            let only_b: Vec<String> = b.1.iter().filter(|n| !has(a.1, n)).cloned().collect();
            if !only_a.is_empty() || (!only_b.is_empty() && !t.new_channels) {
                return Err(CompareError::ChannelMismatch {
                    a: a.0.to_path_buf(),
                    only_a,
                    b: b.0.to_path_buf(),
                    only_b,
                });
            }
            Ok((a.1.to_vec(), only_b))
        }
    }
}

/// Compares `a` (reference) with `b` (under test), both in memory; see the module docs. The
/// band-by-band code of [`compare_files`] run with one band, keeping the per-pixel maps
/// ([`Report::maps`]) for [`write_diff_exr`] and [`write_heat_map_png`].
pub fn compare(a: &ExrImage, b: &ExrImage, t: &Thresholds) -> Result<Report, CompareError> {
    stream::compare_images(a, b, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn difference_rules() {
        assert_eq!(difference(f32::INFINITY, f32::INFINITY), Some(0.0));
        assert_eq!(difference(f32::NAN, f32::NAN), Some(0.0));
        assert_eq!(difference(f32::NAN, 1.0), None);
        assert_eq!(difference(1.0, f32::NAN), None);
        assert_eq!(difference(f32::INFINITY, 3.5), None);
        assert_eq!(difference(f32::INFINITY, f32::NEG_INFINITY), None);
        assert_eq!(difference(1.0, 1.5), Some(0.5));
    }

    #[test]
    fn classes() {
        use ChannelClass as C;
        let f = SampleKind::F32;
        for (name, class) in [
            ("R", C::Colour),
            ("A", C::Colour),
            ("beauty.G", C::Colour),
            ("Z", C::Depth),
            ("depth.Z", C::Depth),
            ("N.Z", C::Normal),
            ("ViewLayer.Normal.X", C::Normal),
            ("P.Z", C::Position),
            ("steps", C::Integer),
            ("crossings", C::Integer),
            ("cell.X", C::Integer),
            ("field.value", C::Other),
        ] {
            assert_eq!(C::of(name, f), class, "{name}");
        }
        assert_eq!(C::of("id", SampleKind::U32), C::Integer);
        // isoview's own channels take their class from the table; the names alone say the same.
        for c in Channel::ALL {
            assert_eq!(C::of(c.name(), f), c.class(), "{c:?}");
            assert_eq!(class_by_name(c.name()), c.class(), "{c:?}");
        }
        assert_eq!(C::parse("color"), Some(C::Colour));
        assert_eq!(C::parse("depth"), Some(C::Depth));
        assert_eq!(C::parse("nope"), None);
    }

    #[test]
    fn thresholds_per_class() {
        let mut t = Thresholds::default();
        assert_eq!(t.fail_for(ChannelClass::Integer), 0.0);
        assert_eq!(t.fail_for(ChannelClass::Depth), DEFAULT_FAIL);
        assert_eq!(t.warn_for(ChannelClass::Integer), 0.0);
        t.fail_class = vec![(ChannelClass::Depth, 1e-3), (ChannelClass::Depth, 2e-3)];
        assert_eq!(t.fail_for(ChannelClass::Depth), 2e-3);
        assert_eq!(t.fail_for(ChannelClass::Colour), DEFAULT_FAIL);
    }

    #[test]
    fn long_name_lists_are_cut() {
        let names: Vec<String> = (0..15).map(|i| format!("c{i}")).collect();
        assert_eq!(list_or_none(&names[..2]), "c0, c1");
        assert!(list_or_none(&names).ends_with("c11 and 3 more"));
        assert_eq!(list_or_none(&[]), "(none)");
    }
}
