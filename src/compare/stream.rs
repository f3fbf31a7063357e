//! The comparison of two EXR images band by band ([`compare_files`], what `isoview compare`
//! runs), so that memory does not grow with the image. It is the only comparison: the
//! whole-image [`super::compare`] of two images in memory is this code run with one band
//! ([`compare_images`]), keeping the per-pixel maps, and [`super::write_diff_exr`] and
//! [`super::write_heat_map_png`] write those maps through the same [`Writers`].
//!
//! ```text
//!   pass 1      bands of rows of A and B (+ a halo) -> per-channel sums, max, counts, pixel
//!               states, coverage, FLIP sum; percentiles: a 16-bit histogram each
//!   pass 2..    (only while a percentile is not pinned down, or to write --diff/--png)
//!               the same bands again -> the percentiles' candidates; the outputs' rows
//! ```
//!
//! Why each part needs what it holds:
//!
//! - Sums, maxima and counts run over the pixels in the whole-image order (row-major, one
//!   channel at a time within a band), so every float is added in the same order.
//! - The shift window looks one row up and down: each band is read with one row of halo.
//! - FLIP's filters reach [`flip_halo`] rows (its spatial and feature filters at 67 ppd, 10
//!   and 9 rows); each band's FLIP is computed on the band plus that halo and only the band's
//!   rows are kept. FLIP clamps at the image border only, so those rows equal the whole
//!   image's map bit for bit.
//! - Nearest-rank percentiles (relative p99, FLIP p50/p95/p99/max) need the k-th smallest of
//!   all values: found exactly by [`super::select`] over one or more further passes, each
//!   re-reading (and for FLIP recomputing) the bands.
//! - The difference EXR's header carries the verdict line, known only after pass 1, so the
//!   outputs are written in pass 2, row by row ([`crate::output::exr::PlaneStream`],
//!   [`crate::output::png::Rgba8Stream`]), each to a temporary file renamed at the end.
//!
//! - FLIP is computed once, in pass 1, and its map (4 bytes a pixel) kept for the later
//!   passes in an unlinked temporary file ([`std::env::temp_dir`]): disk, not memory.
//!
//! Memory: a band of [`band_rows`] rows (fewer for many channels: [`BAND_BYTES`]) plus halos
//! of the channels read, and the rest of a block row and one block decoded (refused over
//! [`MAX_IMAGE_BYTES`] an image), FLIP's working
//! images for those rows (about 100 bytes a pixel), and 1.5 MiB per percentile searched in a
//! pass: FLIP's four, and the relative-error ones of at most [`PERCENTILE_BATCH`] channels, so
//! an EXR with thousands of channels takes more passes, not more memory.

use std::path::Path;

use super::flip::PIXELS_PER_DEGREE;
use super::output::{diff_attributes, heat_rgba8, signed_difference};
use super::rows::ExrRows;
use super::select::{key32, key64, Select};
use super::{
    difference, select_names, tolerance, within, ChannelClass, ChannelStats, CompareError,
    Coverage, FlipStats, PixelMaps, PixelState, Report, Thresholds, Verdict,
};
use crate::frame::Channel;
use crate::output::exr::PlaneStream;
use crate::output::exr::{ExrImage, SampleKind};
use crate::output::png::{to_srgb8, Rgba8Stream};
use crate::output::OutputError;

/// Pixels per band: rows of about this many pixels (at least [`MIN_BAND_ROWS`], at most
/// [`MAX_BAND_ROWS`]). About 2 MiB per channel and image, and FLIP's halo (10 rows each side)
/// adds little to bands of this height.
pub const BAND_PIXELS: usize = 1 << 19;
pub const MIN_BAND_ROWS: usize = 32;
pub const MAX_BAND_ROWS: usize = 256;

/// Channels whose relative-error percentile is searched in one pass (each holds 1.5 MiB of
/// tables while searched); the others wait for a later pass. 64 covers isoview's own EXRs (a
/// dozen channels or so) in the passes they always took.
pub const PERCENTILE_BATCH: usize = 64;

/// Bytes a band's rows of the channels read take in one image at most: bands of files with
/// many channels get fewer rows (down to one), so memory does not grow with the channel count.
/// isoview's own EXRs (a dozen channels) stay far below it at [`MAX_BAND_ROWS`] rows.
pub const BAND_BYTES: u64 = 64 << 20;

/// Bytes one image of a streamed comparison may hold at once: the band and its halo, the rest
/// of a block row, and a block decoded. More (rows of very many channels, or very wide) is
/// refused before anything is read, naming the numbers.
pub const MAX_IMAGE_BYTES: u64 = 512 << 20;

/// The band height [`compare_files`] uses for images `width` pixels wide.
pub fn band_rows(width: usize) -> usize {
    (BAND_PIXELS / width.max(1)).clamp(MIN_BAND_ROWS, MAX_BAND_ROWS)
}

/// Files a comparison writes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Outputs<'p> {
    /// The difference EXR (`--diff`).
    pub diff: Option<&'p Path>,
    /// The heat-map PNG (`--png`).
    pub png: Option<&'p Path>,
}

/// Rows of halo FLIP needs around a band: the larger of its spatial filter's radius and its
/// feature filter's, computed as NVIDIA's code does (`calculateSpatialFilterRadius`, and
/// `ceil(3 * 0.5 * gw * ppd)` with gw = 0.082).
pub fn flip_halo(ppd: f32) -> usize {
    let b_max = 0.04f32; // the largest of the Gaussians' scale parameters b1, b2
    let pi_sq = (std::f64::consts::PI * std::f64::consts::PI) as f32;
    let spatial = (3.0f32 * (b_max / (2.0 * pi_sq)).sqrt() * ppd).ceil() as usize;
    let feature = (3.0f32 * (0.5 * 0.082 * ppd)).ceil() as usize;
    spatial.max(feature)
}

/// The rows of an image's channels as the bands need them: read from a file a band at a time
/// ([`ExrRows`]), or an image already in memory ([`Whole`]).
pub(super) trait Source {
    fn path(&self) -> &Path;
    fn width(&self) -> usize;
    fn height(&self) -> usize;
    /// Every channel's full name and sample type, in file order.
    fn channels(&self) -> Vec<(String, SampleKind)>;
    /// The index of the channel named `name`.
    fn index(&self, name: &str) -> Option<usize>;
    /// Loads only these channels from now on, and starts again at row 0.
    fn keep(&mut self, channels: &[usize]);
    /// Holds rows `lo .. hi` (clamped to the image); rows are asked for top to bottom.
    fn load(&mut self, lo: usize, hi: usize) -> Result<(), CompareError>;
    /// Rows `y0 .. y1` of channel `c`, row-major; they must be loaded.
    fn rows(&self, c: usize, y0: usize, y1: usize) -> &[f32];
    /// The most bytes this source holds while bands of `rows` rows (halo included) of `kept`
    /// channels are read from it; `None` for an image already in memory (nothing to bound).
    fn held_bytes(&self, rows: usize, kept: usize) -> Option<u64>;
}

impl Source for ExrRows {
    fn path(&self) -> &Path {
        &self.path
    }
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn channels(&self) -> Vec<(String, SampleKind)> {
        self.channels.clone()
    }
    fn index(&self, name: &str) -> Option<usize> {
        ExrRows::index(self, name)
    }
    fn keep(&mut self, channels: &[usize]) {
        ExrRows::keep(self, channels)
    }
    fn load(&mut self, lo: usize, hi: usize) -> Result<(), CompareError> {
        Ok(ExrRows::load(self, lo, hi)?)
    }
    fn rows(&self, c: usize, y0: usize, y1: usize) -> &[f32] {
        ExrRows::rows(self, c, y0, y1)
    }
    fn held_bytes(&self, rows: usize, kept: usize) -> Option<u64> {
        // Loads run to the end of the block row holding the last row asked for.
        let held = (rows + self.block_rows()) as u64;
        Some(held.saturating_mul(row_bytes(self.width, kept)).saturating_add(self.block_bytes()))
    }
}

/// Bytes of one row of `kept` channels decoded to `f32`.
fn row_bytes(width: usize, kept: usize) -> u64 {
    (width as u64).saturating_mul(kept as u64).saturating_mul(4)
}

/// An image in memory: every row is always there.
pub(super) struct Whole<'i>(pub &'i ExrImage);

impl Source for Whole<'_> {
    fn path(&self) -> &Path {
        &self.0.path
    }
    fn width(&self) -> usize {
        self.0.width
    }
    fn height(&self) -> usize {
        self.0.height
    }
    fn channels(&self) -> Vec<(String, SampleKind)> {
        self.0.channels.iter().map(|c| (c.name.clone(), c.kind)).collect()
    }
    fn index(&self, name: &str) -> Option<usize> {
        self.0.channels.iter().position(|c| c.name == name)
    }
    fn keep(&mut self, _: &[usize]) {}
    fn load(&mut self, _: usize, _: usize) -> Result<(), CompareError> {
        Ok(())
    }
    fn rows(&self, c: usize, y0: usize, y1: usize) -> &[f32] {
        let w = self.0.width;
        &self.0.channels[c].values[y0 * w..y1 * w]
    }
    fn held_bytes(&self, _: usize, _: usize) -> Option<u64> {
        None
    }
}

/// One compared channel: where it is in each file, its class and thresholds.
struct Plan {
    name: String,
    class: ChannelClass,
    a: usize,
    b: usize,
    fail: f64,
    warn: f64,
}

/// Running statistics of one channel (pass 1).
struct Acc {
    stats: ChannelStats,
    sum: f64,
    sum_sq: f64,
    finite: usize,
}

/// The coverage channel's name, its index in A and in B, and the hit rule.
type CoverageSource = (String, usize, usize, fn(f32) -> bool);

/// The indices of R, G, B in A and in B.
type RgbPair = ([usize; 3], [usize; 3]);

/// The whole comparison's state.
struct Run<'t, S: Source> {
    a: S,
    b: S,
    t: &'t Thresholds,
    w: usize,
    h: usize,
    plans: Vec<Plan>,
    new_channels: Vec<String>,
    /// Coverage channel name and its index in A and B, with the hit rule.
    coverage: Option<CoverageSource>,
    /// R, G, B in A and in B, or why FLIP is not computed (`None`: not asked for).
    flip: Option<Result<RgbPair, String>>,
    halo: usize,
    band_rows: usize,
    /// FLIP's map from pass 1, for the later passes.
    spill: Spill,
    /// Keep the per-pixel maps in the report ([`Report::maps`]; only for one band in memory).
    keep_maps: bool,
}

/// Everything one band gives, in the band's row-major order.
#[derive(Default)]
struct Band {
    states: Vec<PixelState>,
    ratio: Vec<f32>,
    hard: Vec<bool>,
    only_a: usize,
    only_b: usize,
    flip: Option<Vec<f32>>,
}

/// What a pass is for.
struct Pass<'s> {
    /// Pass 1: accumulate the statistics.
    acc: Option<&'s mut Vec<Acc>>,
    /// Per channel, the relative-error percentile being searched (`None` once found or empty).
    rel: &'s mut [Option<Select>],
    /// Which of `rel` this pass searches ([`batch`]).
    rel_now: &'s [bool],
    /// FLIP percentiles being searched, and the running FLIP sum (pass 1).
    flip_sel: &'s mut [Select],
    flip_sum: Option<&'s mut f64>,
    /// Whether this pass needs the channels (statistics, percentiles or outputs) and FLIP.
    need_channels: bool,
    need_flip: bool,
}

/// Compares the files `a` (reference) and `b` band by band; see the module docs. Returns the
/// report and, separately, an error writing `outputs` (the report is complete either way; as
/// with the whole-image path, a failed `--diff` means no `--png` either).
pub fn compare_files(
    a: &Path,
    b: &Path,
    t: &Thresholds,
    outputs: Outputs<'_>,
) -> Result<(Report, Option<OutputError>), CompareError> {
    let rows = ExrRows::open(a).map(|r| band_rows(r.width))?;
    compare_files_in_bands(a, b, t, outputs, rows)
}

/// [`compare_files`] with bands of `band_rows` rows (tests vary it; any value gives the
/// same results).
pub fn compare_files_in_bands(
    a: &Path,
    b: &Path,
    t: &Thresholds,
    outputs: Outputs<'_>,
    band_rows: usize,
) -> Result<(Report, Option<OutputError>), CompareError> {
    let a = ExrRows::open(a)?;
    let b = ExrRows::open(b)?;
    let mut run = Run::plan(a, b, t, band_rows.max(1))?;
    run.compare(outputs)
}

/// The whole-image comparison of two images in memory ([`super::compare`]): one band, the
/// per-pixel maps kept in the report for [`super::write_diff_exr`] and
/// [`super::write_heat_map_png`].
pub(super) fn compare_images(
    a: &ExrImage,
    b: &ExrImage,
    t: &Thresholds,
) -> Result<Report, CompareError> {
    let mut run = Run::plan(Whole(a), Whole(b), t, a.height.max(1))?;
    run.keep_maps = true;
    let (report, _) = run.compare(Outputs::default())?;
    Ok(report)
}

impl<'t, S: Source> Run<'t, S> {
    fn plan(a: S, b: S, t: &'t Thresholds, band_rows: usize) -> Result<Run<'t, S>, CompareError> {
        if (a.width(), a.height()) != (b.width(), b.height()) {
            return Err(CompareError::SizeMismatch {
                a: a.path().to_path_buf(),
                a_size: (a.width(), a.height()),
                b: b.path().to_path_buf(),
                b_size: (b.width(), b.height()),
            });
        }
        let (ca, cb) = (a.channels(), b.channels());
        let names =
            |c: &[(String, SampleKind)]| c.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
        let (selected, new_channels) =
            select_names((a.path(), &names(&ca)), (b.path(), &names(&cb)), t)?;
        let mut plans = Vec::new();
        for name in selected {
            let (Some(ia), Some(ib)) = (a.index(&name), b.index(&name)) else {
                continue; // select_names checked both have it
            };
            let class = ChannelClass::of(&name, ca[ia].1);
            plans.push(Plan {
                name,
                class,
                a: ia,
                b: ib,
                fail: t.fail_for(class),
                warn: t.warn_for(class),
            });
        }
        let both = |name: &str| Some((a.index(name)?, b.index(name)?));
        let coverage = match both(Channel::Z.name()) {
            Some((ia, ib)) => {
                Some((Channel::Z.name().to_string(), ia, ib, f32::is_finite as fn(f32) -> bool))
            }
            None => both(Channel::A.name()).map(|(ia, ib)| {
                (Channel::A.name().to_string(), ia, ib, (|v| v > 0.0) as fn(f32) -> bool)
            }),
        };
        let flip = (t.flip || t.flip_fail.is_some()).then(|| flip_channels(&a, &b));
        let shift_halo = usize::from(t.shift);
        let flip_ok = matches!(flip, Some(Ok(_)));
        let flip_rows = if flip_ok { flip_halo(PIXELS_PER_DEGREE) } else { 0 };
        let halo = shift_halo.max(flip_rows);
        let (w, h) = (a.width(), a.height());
        // The most channels a pass reads ([`Run::keep`]): bands shrink so their rows of them
        // fit [`BAND_BYTES`] (the results do not depend on the band height), and what is left
        // over [`MAX_IMAGE_BYTES`] is refused.
        let kept = plans.len() + usize::from(coverage.is_some()) + if flip_ok { 3 } else { 0 };
        let mut band_rows = band_rows;
        if a.held_bytes(1, 1).is_some() {
            let fit = BAND_BYTES / row_bytes(w, kept).max(1);
            band_rows = band_rows.min(usize::try_from(fit).unwrap_or(usize::MAX).max(1));
        }
        for s in [&a, &b] {
            let held = s.held_bytes(band_rows + 2 * halo, kept).unwrap_or(0);
            if held > MAX_IMAGE_BYTES {
                return Err(CompareError::TooLarge {
                    path: s.path().to_path_buf(),
                    channels: kept,
                    width: w,
                    mib: held.div_ceil(1 << 20),
                });
            }
        }
        Ok(Run {
            a,
            b,
            t,
            w,
            h,
            plans,
            new_channels,
            coverage,
            flip,
            halo,
            band_rows,
            spill: Spill::default(),
            keep_maps: false,
        })
    }

    /// Loads only what a pass needs: the compared and coverage channels, and R, G, B for FLIP.
    fn keep(&mut self, channels: bool, flip: bool) {
        let (mut ka, mut kb) = (Vec::new(), Vec::new());
        if channels {
            for p in &self.plans {
                ka.push(p.a);
                kb.push(p.b);
            }
            if let Some((_, ia, ib, _)) = &self.coverage {
                ka.push(*ia);
                kb.push(*ib);
            }
        }
        if let (true, Some(Ok((ra, rb)))) = (flip, &self.flip) {
            ka.extend_from_slice(ra);
            kb.extend_from_slice(rb);
        }
        self.a.keep(&ka);
        self.b.keep(&kb);
    }

    fn compare(
        &mut self,
        outputs: Outputs<'_>,
    ) -> Result<(Report, Option<OutputError>), CompareError> {
        let n = self.w * self.h;
        let mut acc: Vec<Acc> = self.plans.iter().map(Acc::new).collect();
        let mut rel: Vec<Option<Select>> =
            self.plans.iter().map(|_| Some(Select::new(64, 0))).collect();
        let flip_ok = matches!(self.flip, Some(Ok(_)));
        let mut flip_sel: Vec<Select> = if flip_ok {
            [0.50, 0.95, 0.99, 1.0].iter().map(|&p| Select::new(32, nearest_rank(p, n))).collect()
        } else {
            Vec::new()
        };
        let mut flip_sum = 0f64;

        // Pass 1: statistics, states, FLIP sum; first digits of the percentiles.
        let mut totals = Totals::default();
        let mut maps = self.keep_maps.then(|| PixelMaps {
            pixels: Vec::new(),
            ratio: Vec::new(),
            flip: flip_ok.then(Vec::new),
        });
        let mut rel_now = batch(&rel);
        {
            let pass = Pass {
                acc: Some(&mut acc),
                rel: &mut rel,
                rel_now: &rel_now,
                flip_sel: &mut flip_sel,
                flip_sum: Some(&mut flip_sum),
                need_channels: true,
                need_flip: flip_ok,
            };
            self.pass(pass, |_, _, _, band| {
                totals.add(band);
                if let Some(m) = &mut maps {
                    m.pixels.extend_from_slice(&band.states);
                    m.ratio.extend_from_slice(&band.ratio);
                    if let (Some(f), Some(bf)) = (&mut m.flip, &band.flip) {
                        f.extend_from_slice(bf);
                    }
                }
                Ok(())
            })?;
        }
        // Ranks of the relative errors are known now that the finite pairs are counted.
        for (sel, a) in rel.iter_mut().zip(&acc) {
            if a.finite == 0 {
                *sel = None;
            } else if let Some(s) = sel {
                s.set_rank(nearest_rank(0.99, a.finite));
            }
        }
        end_pass(&mut rel, &rel_now, &mut flip_sel)?;

        let flip_mean = flip_ok.then(|| (flip_sum / n as f64) as f32);
        let mut report = self.report(&acc, &totals, flip_mean);
        report.maps = maps;

        // Pass 2: the outputs, and more digits of the percentiles; then until all are found.
        let mut writers = Writers::create(&report, outputs);
        let mut write = writers.any();
        let searching = |rel: &[Option<Select>], flip: &[Select]| {
            rel.iter().flatten().any(|s| !s.done()) || flip.iter().any(|s| !s.done())
        };
        while write || searching(&rel, &flip_sel) {
            let need_flip =
                flip_sel.iter().any(|s| !s.done()) || (write && writers.diff.is_some() && flip_ok);
            let need_channels = write || rel.iter().flatten().any(|s| !s.done());
            rel_now = batch(&rel);
            let pass = Pass {
                acc: None,
                rel: &mut rel,
                rel_now: &rel_now,
                flip_sel: &mut flip_sel,
                flip_sum: None,
                need_channels,
                need_flip,
            };
            self.pass(pass, |run, y0, y1, band| {
                if write {
                    let diffs = || {
                        run.plans
                            .iter()
                            .map(|p| diff_plane(run.a.rows(p.a, y0, y1), run.b.rows(p.b, y0, y1)))
                            .collect()
                    };
                    writers.push(diffs, &band.states, &band.ratio, band.flip.as_deref());
                }
                Ok(())
            })?;
            end_pass(&mut rel, &rel_now, &mut flip_sel)?;
            write = false;
        }
        let output_error = writers.finish();

        for (s, sel) in report.channels.iter_mut().zip(&rel) {
            if let Some(v) = sel.as_ref().and_then(Select::f64) {
                s.rel_p99 = v;
            }
        }
        if let Some(f) = &mut report.flip {
            let v: Vec<f32> = flip_sel.iter().map(|s| s.f32().unwrap_or(0.0)).collect();
            (f.p50, f.p95, f.p99, f.max) = (v[0], v[1], v[2], v[3]);
        }
        Ok((report, output_error))
    }
}

/// 0-based nearest rank of percentile `p` in [0, 1] among `n` values (as `percentile`).
fn nearest_rank(p: f64, n: usize) -> u64 {
    (((p * n as f64).ceil() as usize).clamp(1, n.max(1)) - 1) as u64
}

/// The first [`PERCENTILE_BATCH`] relative-error percentiles still searched: those one pass
/// searches.
fn batch(rel: &[Option<Select>]) -> Vec<bool> {
    let mut left = PERCENTILE_BATCH;
    rel.iter()
        .map(|s| {
            let now = left > 0 && s.as_ref().is_some_and(|s| !s.done());
            left -= usize::from(now);
            now
        })
        .collect()
}

fn end_pass(
    rel: &mut [Option<Select>],
    rel_now: &[bool],
    flip: &mut [Select],
) -> Result<(), CompareError> {
    let rel = rel.iter_mut().zip(rel_now).filter(|(_, &now)| now).filter_map(|(s, _)| s.as_mut());
    for s in rel.chain(flip.iter_mut()) {
        s.end().map_err(|e| CompareError::Output(OutputError::invalid(Path::new("compare"), e)))?;
    }
    Ok(())
}

/// R, G, B of both images, or why FLIP cannot run.
fn flip_channels<S: Source>(a: &S, b: &S) -> Result<RgbPair, String> {
    if a.width() == 0 || a.height() == 0 {
        return Err("not computed: the images differ in size".into());
    }
    u32::try_from(a.width()).map_err(|_| "image too wide")?;
    u32::try_from(a.height()).map_err(|_| "image too tall")?;
    let rgb = |img: &S| -> Result<[usize; 3], String> {
        let mut out = [0; 3];
        for (slot, name) in out.iter_mut().zip(["R", "G", "B"]) {
            *slot = img.index(name).ok_or_else(|| {
                format!("not computed: {} has no {name} channel", img.path().display())
            })?;
        }
        Ok(out)
    };
    Ok((rgb(a)?, rgb(b)?))
}

impl Acc {
    fn new(p: &Plan) -> Acc {
        Acc {
            stats: ChannelStats {
                name: p.name.clone(),
                class: p.class,
                fail: p.fail,
                max_abs: 0.0,
                max_at: None,
                mean_abs: 0.0,
                rmse: 0.0,
                rel_p99: 0.0,
                over_fail: 0,
                nonfinite: 0,
                identical: true,
            },
            sum: 0.0,
            sum_sq: 0.0,
            finite: 0,
        }
    }
}

/// Pixel counts over the whole image (pass 1).
#[derive(Default)]
struct Totals {
    failing: usize,
    forgiven: usize,
    warning: usize,
    hard_failing: usize,
    only_a: usize,
    only_b: usize,
}

impl Totals {
    fn add(&mut self, band: &Band) {
        for (&state, &hard) in band.states.iter().zip(&band.hard) {
            match state {
                PixelState::Fail => self.failing += 1,
                PixelState::Forgiven => self.forgiven += 1,
                _ => {}
            }
            if matches!(state, PixelState::Fail | PixelState::Forgiven | PixelState::Warn) {
                self.warning += 1;
            }
            if hard && state != PixelState::Forgiven {
                self.hard_failing += 1;
            }
        }
        self.only_a += band.only_a;
        self.only_b += band.only_b;
    }
}

impl<S: Source> Run<'_, S> {
    /// One pass over the bands, top to bottom; `on_band` sees each band's results.
    fn pass(
        &mut self,
        mut pass: Pass<'_>,
        mut on_band: impl FnMut(&Self, usize, usize, &Band) -> Result<(), CompareError>,
    ) -> Result<(), CompareError> {
        // FLIP is computed in pass 1 only (R, G, B read then); later passes read its spill.
        let first = pass.flip_sum.is_some();
        self.keep(pass.need_channels, pass.need_flip && first);
        if pass.need_flip {
            self.spill.rewind()?;
        }
        let rel_now = pass.rel_now;
        let rel = pass.rel.iter_mut().zip(rel_now).filter(|(_, &now)| now);
        rel.filter_map(|(s, _)| s.as_mut()).for_each(Select::begin);
        pass.flip_sel.iter_mut().for_each(Select::begin);
        let mut y0 = 0;
        while y0 < self.h {
            let y1 = (y0 + self.band_rows).min(self.h);
            let lo = y0.saturating_sub(self.halo);
            self.a.load(lo, y1 + self.halo)?;
            self.b.load(lo, y1 + self.halo)?;
            let mut band = self.band(y0, y1, &mut pass);
            if pass.need_flip {
                let map = if pass.flip_sum.is_some() {
                    let map = self.flip_rows(y0, y1);
                    self.spill.write(&map)?;
                    map
                } else {
                    self.spill.read((y1 - y0) * self.w)?
                };
                for s in pass.flip_sel.iter_mut() {
                    map.iter().for_each(|&v| s.offer(key32(v)));
                }
                if let Some(sum) = pass.flip_sum.as_deref_mut() {
                    map.iter().for_each(|&v| *sum += f64::from(v));
                }
                band.flip = Some(map);
            }
            on_band(self, y0, y1, &band)?;
            y0 = y1;
        }
        Ok(())
    }

    /// Rows `y0 .. y1`: per-channel differences, pixel states, coverage and FLIP, as the pass
    /// needs them (the rules of the module docs of [`super`], pixel by pixel).
    fn band(&self, y0: usize, y1: usize, pass: &mut Pass<'_>) -> Band {
        let (w, t, rel) = (self.w, self.t, self.t.fail_relative);
        let len = (y1 - y0) * w;
        let mut band = Band::default();
        if pass.need_channels {
            let mut ratio = vec![0f32; len];
            let (mut over_fail, mut over_warn) = (vec![false; len], vec![false; len]);
            let (mut differs, mut hard) = (vec![false; len], vec![false; len]);
            for (k, p) in self.plans.iter().enumerate() {
                let (pa, pb) = (self.a.rows(p.a, y0, y1), self.b.rows(p.b, y0, y1));
                let mut acc = pass.acc.as_deref_mut().map(|v| &mut v[k]);
                let mut sel = pass.rel[k].as_mut().filter(|_| pass.rel_now[k]);
                for j in 0..len {
                    let (x, y) = (pa[j], pb[j]);
                    let d = difference(x, y);
                    let (over, over_w, r) = match d {
                        None => (true, true, f32::INFINITY),
                        Some(d) => {
                            let tol = tolerance(x, y, p.fail, rel);
                            let tol_w = tolerance(x, y, p.warn, rel);
                            let r = if d == 0.0 {
                                0.0
                            } else if tol > 0.0 {
                                (d / tol) as f32
                            } else {
                                f32::INFINITY
                            };
                            (d > tol, d > tol_w, r)
                        }
                    };
                    let different = d != Some(0.0);
                    if let Some(d) = d.filter(|_| x.is_finite()) {
                        let m = f64::from(x.abs().max(y.abs()));
                        if let Some(s) = sel.as_deref_mut() {
                            s.offer(key64(if m > 0.0 { d / m } else { 0.0 }));
                        }
                        if let Some(a) = acc.as_deref_mut() {
                            a.finite += 1;
                            a.sum += d;
                            a.sum_sq += d * d;
                            if d > a.stats.max_abs || a.stats.max_at.is_none() {
                                a.stats.max_abs = d;
                                a.stats.max_at = Some((j % w, y0 + j / w));
                            }
                        }
                    }
                    if let Some(a) = acc.as_deref_mut() {
                        a.stats.nonfinite += usize::from(d.is_none());
                        a.stats.over_fail += usize::from(over);
                        a.stats.identical &= !different;
                    }
                    differs[j] |= different;
                    over_fail[j] |= over;
                    over_warn[j] |= over_w;
                    ratio[j] = ratio[j].max(r);
                    if let Some(limit) = t.hard_fail {
                        hard[j] |= d.map_or(true, |d| d > limit);
                    }
                }
            }
            band.states = (0..len)
                .map(|j| {
                    if over_fail[j] {
                        if t.shift && self.forgives(j % w, y0 + j / w) {
                            PixelState::Forgiven
                        } else {
                            PixelState::Fail
                        }
                    } else if over_warn[j] {
                        PixelState::Warn
                    } else if differs[j] {
                        PixelState::Close
                    } else {
                        PixelState::Same
                    }
                })
                .collect();
            if let Some((_, ia, ib, hit)) = &self.coverage {
                let (ca, cb) = (self.a.rows(*ia, y0, y1), self.b.rows(*ib, y0, y1));
                for (&x, &y) in ca.iter().zip(cb) {
                    band.only_a += usize::from(hit(x) && !hit(y));
                    band.only_b += usize::from(!hit(x) && hit(y));
                }
            }
            band.ratio = ratio;
            band.hard = hard;
        }
        band
    }

    /// The shift-window rule (module docs of [`super`]) for the failing pixel (x, y).
    fn forgives(&self, x: usize, y: usize) -> bool {
        let (w, h) = (self.w as i64, self.h as i64);
        let window: Vec<(usize, usize)> = (-1i64..=1)
            .flat_map(|dy| (-1i64..=1).map(move |dx| (x as i64 + dx, y as i64 + dy)))
            .filter(|&(u, v)| u >= 0 && v >= 0 && u < w && v < h)
            .map(|(u, v)| (u as usize, v as usize))
            .collect();
        let at = |img: &S, c: usize, (u, v): (usize, usize)| img.rows(c, v, v + 1)[u];
        if let Some((_, ia, ib, hit)) = &self.coverage {
            let ca = |q| hit(at(&self.a, *ia, q));
            let cb = |q| hit(at(&self.b, *ib, q));
            let edge = |c: &dyn Fn((usize, usize)) -> bool| {
                window.iter().any(|&q| c(q)) && window.iter().any(|&q| !c(q))
            };
            if ca((x, y)) != cb((x, y)) && edge(&ca) && edge(&cb) {
                return true;
            }
        }
        let rel = self.t.fail_relative;
        let matches = |from_a: bool, q: (usize, usize)| {
            self.plans.iter().all(|p| {
                let (v, u) = if from_a {
                    (at(&self.a, p.a, (x, y)), at(&self.b, p.b, q))
                } else {
                    (at(&self.b, p.b, (x, y)), at(&self.a, p.a, q))
                };
                within(v, u, p.fail, rel)
            })
        };
        window.iter().any(|&q| matches(true, q)) && window.iter().any(|&q| matches(false, q))
    }

    /// FLIP's error map for rows `y0 .. y1`, computed on them plus the halo.
    fn flip_rows(&self, y0: usize, y1: usize) -> Vec<f32> {
        let Some(Ok((ra, rb))) = &self.flip else {
            return Vec::new();
        };
        let w = self.w;
        let halo = flip_halo(PIXELS_PER_DEGREE);
        let (fy0, fy1) = (y0.saturating_sub(halo), (y1 + halo).min(self.h));
        let srgb = |img: &S, c: &[usize; 3]| -> Vec<u8> {
            let (r, g, b) =
                (img.rows(c[0], fy0, fy1), img.rows(c[1], fy0, fy1), img.rows(c[2], fy0, fy1));
            (0..r.len())
                .flat_map(|i| {
                    let [r, g, b, _] = to_srgb8([r[i], g[i], b[i], 1.0]);
                    [r, g, b]
                })
                .collect()
        };
        // The sizes fit in u32: `flip_channels` checked.
        let (fw, fh) = (w as u32, (fy1 - fy0) as u32);
        let reference = nv_flip::FlipImageRgb8::with_data(fw, fh, &srgb(&self.a, ra));
        let test = nv_flip::FlipImageRgb8::with_data(fw, fh, &srgb(&self.b, rb));
        let map = nv_flip::flip(reference, test, PIXELS_PER_DEGREE).to_vec();
        map[(y0 - fy0) * w..(y1 - fy0) * w].to_vec()
    }

    /// The report from pass 1 (percentiles still 0: filled in when found).
    fn report(&self, acc: &[Acc], totals: &Totals, flip_mean: Option<f32>) -> Report {
        let t = self.t;
        let n = self.w * self.h;
        let channels: Vec<ChannelStats> = acc
            .iter()
            .map(|a| {
                let mut s = a.stats.clone();
                if a.finite > 0 {
                    s.mean_abs = a.sum / a.finite as f64;
                    s.rmse = (a.sum_sq / a.finite as f64).sqrt();
                }
                s
            })
            .collect();
        let flip = flip_mean.map(|mean| FlipStats {
            mean,
            p50: 0.0,
            p95: 0.0,
            p99: 0.0,
            max: 0.0,
            pixels_per_degree: PIXELS_PER_DEGREE,
        });
        let flip_note = match &self.flip {
            Some(Err(note)) => Some(note.clone()),
            _ => None,
        };
        let percent = |k: usize| 100.0 * k as f64 / n.max(1) as f64;
        let flip_over = match (t.flip_fail, &flip) {
            (Some(limit), Some(f)) => f64::from(f.mean) > limit,
            (Some(_), None) => true,
            _ => false,
        };
        let verdict =
            if percent(totals.failing) > t.fail_percent || totals.hard_failing > 0 || flip_over {
                Verdict::Fail
            } else if percent(totals.warning) > t.warn_percent {
                Verdict::Warn
            } else if channels.iter().all(|s| s.identical) {
                Verdict::Identical
            } else {
                Verdict::Pass
            };
        Report {
            a: self.a.path().to_path_buf(),
            b: self.b.path().to_path_buf(),
            width: self.w,
            height: self.h,
            thresholds: t.clone(),
            channels,
            new_channels: self.new_channels.clone(),
            coverage: self.coverage.as_ref().map(|(name, ..)| Coverage {
                channel: name.clone(),
                only_a: totals.only_a,
                only_b: totals.only_b,
            }),
            failing_pixels: totals.failing,
            forgiven_pixels: totals.forgiven,
            warning_pixels: totals.warning,
            hard_failing_pixels: totals.hard_failing,
            flip,
            flip_note,
            verdict,
            maps: None,
        }
    }
}

/// B − A of one channel, pixel by pixel (the `diff.<name>` plane of the difference EXR).
pub(super) fn diff_plane(a: &[f32], b: &[f32]) -> Vec<f32> {
    a.iter().zip(b).map(|(&x, &y)| signed_difference(x, y)).collect()
}

/// The output files being written (pass 2, or at once from a whole-image report's maps), and
/// the first error writing them.
pub(super) struct Writers {
    diff: Option<PlaneStream>,
    png: Option<Rgba8Stream>,
    error: Option<OutputError>,
    shift: bool,
}

impl Writers {
    /// Starts the outputs; a `--diff` that cannot be started means no `--png` either.
    pub(super) fn create(report: &Report, outputs: Outputs<'_>) -> Writers {
        let mut writers =
            Writers { diff: None, png: None, error: None, shift: report.thresholds.shift };
        if let Some(path) = outputs.diff {
            let mut names: Vec<String> =
                report.channels.iter().map(|s| format!("diff.{}", s.name)).collect();
            names.push("fail".into());
            if writers.shift {
                names.push("forgiven".into());
            }
            names.push("ratio".into());
            if report.flip.is_some() {
                names.push("flip".into());
            }
            let attributes = diff_attributes(report);
            match PlaneStream::create(path, report.width, report.height, &names, &attributes) {
                Ok(s) => writers.diff = Some(s),
                Err(e) => {
                    writers.error = Some(e);
                    return writers;
                }
            }
        }
        if let Some(path) = outputs.png {
            let size = (u32::try_from(report.width), u32::try_from(report.height));
            let created = match size {
                (Ok(w), Ok(h)) => Rgba8Stream::create(path, w, h),
                (Err(_), _) => Err(OutputError::invalid(path, "image too wide")),
                (_, Err(_)) => Err(OutputError::invalid(path, "image too tall")),
            };
            match created {
                Ok(s) => writers.png = Some(s),
                Err(e) => {
                    writers.diff = None;
                    writers.error = Some(e);
                }
            }
        }
        writers
    }

    fn any(&self) -> bool {
        self.diff.is_some() || self.png.is_some()
    }

    /// The next rows of each output: each compared channel's B − A (`diffs`, asked for only
    /// when a difference EXR is written), the pixels' states and ratios, and FLIP's map.
    pub(super) fn push(
        &mut self,
        diffs: impl FnOnce() -> Vec<Vec<f32>>,
        states: &[PixelState],
        ratio: &[f32],
        flip: Option<&[f32]>,
    ) {
        if let Some(diff) = &mut self.diff {
            let mut planes = diffs();
            let mask = |want: PixelState| {
                states.iter().map(|&p| if p == want { 1.0 } else { 0.0 }).collect()
            };
            planes.push(mask(PixelState::Fail));
            if self.shift {
                planes.push(mask(PixelState::Forgiven));
            }
            planes.push(ratio.to_vec());
            if let Some(flip) = flip {
                planes.push(flip.to_vec());
            }
            let refs: Vec<&[f32]> = planes.iter().map(Vec::as_slice).collect();
            if let Err(e) = diff.push_rows(&refs) {
                self.error = Some(e);
                self.diff = None;
                self.png = None;
                return;
            }
        }
        if let Some(png) = &mut self.png {
            let rgba: Vec<u8> =
                states.iter().zip(ratio).flat_map(|(&s, &r)| heat_rgba8(s, r)).collect();
            if let Err(e) = png.push_rows(&rgba) {
                self.error = Some(e);
                self.png = None;
            }
        }
    }

    /// Moves the files into place; the first error, if any.
    pub(super) fn finish(mut self) -> Option<OutputError> {
        if let Some(diff) = self.diff.take() {
            if let Err(e) = diff.finish() {
                return Some(e);
            }
        }
        if let Some(png) = self.png.take() {
            if let Err(e) = png.finish() {
                return Some(e);
            }
        }
        self.error
    }
}

/// FLIP's error map written in pass 1 and read back, band by band, in later passes: an
/// unlinked temporary file (gone when the process ends, whatever happens).
#[derive(Default)]
struct Spill {
    file: Option<std::fs::File>,
    writer: Option<std::io::BufWriter<std::fs::File>>,
    reader: Option<std::io::BufReader<std::fs::File>>,
}

impl Spill {
    fn error(e: std::io::Error) -> CompareError {
        CompareError::Output(OutputError::io(&std::env::temp_dir(), "spill FLIP to", e))
    }

    /// Starts writing (first call) or reading from the top (later calls).
    fn rewind(&mut self) -> Result<(), CompareError> {
        use std::io::{Seek, SeekFrom, Write};
        match &self.file {
            None => {
                let path = std::env::temp_dir().join(format!(
                    ".isoview-compare-flip.{}.{:?}.tmp",
                    std::process::id(),
                    std::time::SystemTime::now()
                        .duration_since(std::time::UNIX_EPOCH)
                        .unwrap_or_default()
                        .as_nanos()
                ));
                let file = std::fs::OpenOptions::new()
                    .read(true)
                    .write(true)
                    .create_new(true)
                    .open(&path)
                    .map_err(Self::error)?;
                let _ = std::fs::remove_file(&path); // unlinked: the open file stays
                self.writer = Some(std::io::BufWriter::new(file.try_clone().map_err(Self::error)?));
                self.file = Some(file);
            }
            Some(file) => {
                if let Some(mut w) = self.writer.take() {
                    w.flush().map_err(Self::error)?;
                }
                let mut f = file.try_clone().map_err(Self::error)?;
                f.seek(SeekFrom::Start(0)).map_err(Self::error)?;
                self.reader = Some(std::io::BufReader::new(f));
            }
        }
        Ok(())
    }

    fn write(&mut self, values: &[f32]) -> Result<(), CompareError> {
        use std::io::Write;
        let w =
            self.writer.as_mut().ok_or_else(|| Self::error(std::io::Error::other("not open")))?;
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        w.write_all(&bytes).map_err(Self::error)
    }

    fn read(&mut self, n: usize) -> Result<Vec<f32>, CompareError> {
        use std::io::Read;
        let r =
            self.reader.as_mut().ok_or_else(|| Self::error(std::io::Error::other("not open")))?;
        let mut bytes = vec![0u8; n * 4];
        r.read_exact(&mut bytes).map_err(Self::error)?;
        Ok(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flip_halo_is_the_wider_filter_radius() {
        // At 67 ppd: spatial ceil(3 * sqrt(0.04 / (2 pi^2)) * 67) = 10, feature ceil(8.24) = 9.
        assert_eq!(flip_halo(PIXELS_PER_DEGREE), 10);
        assert_eq!(flip_halo(10.0), 2);
    }

    #[test]
    fn band_heights() {
        assert_eq!(band_rows(4096), 128);
        assert_eq!(band_rows(1), MAX_BAND_ROWS);
        assert_eq!(band_rows(1 << 20), MIN_BAND_ROWS);
        assert_eq!(nearest_rank(0.99, 100), 98);
        assert_eq!(nearest_rank(1.0, 7), 6);
        assert_eq!(nearest_rank(0.5, 1), 0);
    }

    /// An image of `channels` channels, `width` wide, read in blocks of 16 rows: its sizes
    /// and [`ExrRows`]'s bound on what reading it holds, without any pixels.
    struct Sized {
        path: std::path::PathBuf,
        width: usize,
        channels: Vec<(String, SampleKind)>,
    }

    impl Source for Sized {
        fn path(&self) -> &Path {
            &self.path
        }
        fn width(&self) -> usize {
            self.width
        }
        fn height(&self) -> usize {
            64
        }
        fn channels(&self) -> Vec<(String, SampleKind)> {
            self.channels.clone()
        }
        fn index(&self, name: &str) -> Option<usize> {
            self.channels.iter().position(|(n, _)| n == name)
        }
        fn keep(&mut self, _: &[usize]) {}
        fn load(&mut self, _: usize, _: usize) -> Result<(), CompareError> {
            unreachable!("plan only")
        }
        fn rows(&self, _: usize, _: usize, _: usize) -> &[f32] {
            unreachable!("plan only")
        }
        fn held_bytes(&self, rows: usize, kept: usize) -> Option<u64> {
            let block = 16 * row_bytes(self.width, self.channels.len());
            Some((rows + 16) as u64 * row_bytes(self.width, kept) + block)
        }
    }

    fn sized(width: usize, channels: usize) -> Sized {
        let names = (0..channels).map(|i| (format!("c{i}"), SampleKind::F32)).collect();
        Sized { path: "wide.exr".into(), width, channels: names }
    }

    #[test]
    fn bands_shrink_with_the_channels_and_what_cannot_fit_is_refused() {
        let t = Thresholds::default();
        // isoview's own EXRs keep their bands.
        let run = Run::plan(sized(1920, 12), sized(1920, 12), &t, band_rows(1920)).unwrap();
        assert_eq!(run.band_rows, MAX_BAND_ROWS);
        // 512 channels of 512 pixels (1 MiB a row): 64 rows fit BAND_BYTES.
        let run = Run::plan(sized(512, 512), sized(512, 512), &t, 256).unwrap();
        assert_eq!(run.band_rows, 64);
        // One row of 4096 channels of 8192 pixels is 128 MiB: a band of one row and a block of
        // 16 (with the decoded block: 4 GiB) cannot fit; refused naming the file and numbers.
        let err = Run::plan(sized(8192, 4096), sized(8192, 4096), &t, 256).err().unwrap();
        let msg = err.to_string();
        assert!(
            msg.starts_with("wide.exr: comparing 4096 channels of rows 8192 pixels wide needs"),
            "{msg}"
        );
        assert!(msg.contains("over compare's limit of 512 MiB an image; compare fewer"), "{msg}");
    }
}
