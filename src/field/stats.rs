//! Summary statistics of a grid's samples, for `isoview stats` and for isovalues picked from
//! the data (`isovalue_sigma`, `isovalue_percentile`).
//!
//! - mean and σ over all samples, σ the population standard deviation (divided by n, as
//!   NumPy's `std` and the cryo-EM "rms" of mrcfile and ChimeraX), both summed in f64;
//! - percentiles by NumPy's default (`method = "linear"`): for p in [0, 100] the sorted
//!   samples' value at fractional rank `p / 100 * (n - 1)`, interpolated linearly between
//!   the two neighbouring ranks.
//!
//! Missing data (NaN or ±inf samples, [`crate::field::interpolant::is_missing`]) is counted
//! ([`Stats::missing`]) and left out of everything else. A grid with no finite sample has no
//! mean, σ or percentile ([`moments`] and [`Stats::percentile`] give None): a 0 there would
//! be a figure of data that is not there, and an isovalue picked from it a made-up one.

use crate::field::interpolant::is_missing;

/// Statistics of a set of samples.
#[derive(Clone, Debug)]
pub struct Stats {
    /// Samples, missing ones included.
    pub count: usize,
    /// Samples that are missing data (NaN or ±inf).
    pub missing: usize,
    pub min: f64,
    pub max: f64,
    pub mean: f64,
    /// Population standard deviation.
    pub sigma: f64,
    sorted: Vec<f32>,
}

impl Stats {
    /// The statistics of `values` (a sampled grid's), the missing ones counted only.
    pub fn of(values: &[f32]) -> Stats {
        let count = values.len();
        let (mean, sigma) = moments(values).unwrap_or((f64::NAN, f64::NAN));
        let mut sorted: Vec<f32> = values.iter().copied().filter(|&v| !missing(v)).collect();
        let missing = count - sorted.len();
        sorted.sort_unstable_by(f32::total_cmp);
        let (min, max) = match (sorted.first(), sorted.last()) {
            (Some(&a), Some(&b)) => (a as f64, b as f64),
            _ => (0.0, 0.0),
        };
        Stats { count, missing, min, max, mean, sigma, sorted }
    }

    /// Samples that are not missing data.
    pub fn finite(&self) -> usize {
        self.sorted.len()
    }

    /// The `p`-th percentile (0..=100), NumPy's linear rule; None without a finite sample.
    pub fn percentile(&self, p: f64) -> Option<f64> {
        let s = &self.sorted;
        if s.is_empty() {
            return None;
        }
        let rank = (p.clamp(0.0, 100.0) / 100.0) * (s.len() - 1) as f64;
        let lo = rank.floor() as usize;
        let hi = (lo + 1).min(s.len() - 1);
        let (a, b) = (s[lo] as f64, s[hi] as f64);
        Some(a + (b - a) * (rank - lo as f64))
    }

    /// Counts in `bins` equal bins over [min, max] (the last bin includes max).
    pub fn histogram(&self, bins: usize) -> Vec<usize> {
        let mut counts = vec![0usize; bins.max(1)];
        let width = self.max - self.min;
        for &v in &self.sorted {
            let b = if width > 0.0 {
                (((v as f64 - self.min) / width) * bins as f64).floor() as usize
            } else {
                0
            };
            counts[b.min(bins.max(1) - 1)] += 1;
        }
        counts
    }
}

/// Whether a sample is missing data.
fn missing(v: f32) -> bool {
    is_missing(f64::from(v))
}

/// Mean and population σ of the samples of `values` that are not missing data, without the
/// sorted copy [`Stats::of`] keeps; None when every sample is missing.
pub fn moments(values: &[f32]) -> Option<(f64, f64)> {
    let finite = || values.iter().filter(|&&v| !missing(v)).map(|&v| v as f64);
    let n = finite().count();
    if n == 0 {
        return None;
    }
    let n = n as f64;
    let mean = finite().sum::<f64>() / n;
    let var = finite().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    Some((mean, var.sqrt()))
}

#[cfg(test)]
mod tests {
    use super::Stats;

    #[test]
    fn matches_numpy() {
        // numpy: np.percentile([3, 1, 4, 1, 5, 9, 2, 6], [0, 10, 25, 50, 90, 100])
        //   -> [1., 1., 1.75, 3.5, 6.9, 9.]; mean 3.875, std 2.5708704751503917, np.histogram(a, 4) -> [3, 2, 2, 1]
        let s = Stats::of(&[3.0, 1.0, 4.0, 1.0, 5.0, 9.0, 2.0, 6.0]);
        for (p, want) in
            [(0.0, 1.0), (10.0, 1.0), (25.0, 1.75), (50.0, 3.5), (90.0, 6.9), (100.0, 9.0)]
        {
            let got = s.percentile(p).unwrap();
            assert!((got - want).abs() < 1e-12, "p{p}: {got}");
        }
        assert_eq!(s.mean, 3.875);
        assert!((s.sigma - 2.570_870_475_150_391_7).abs() < 1e-12, "{}", s.sigma);
        assert_eq!((s.min, s.max), (1.0, 9.0));
        assert_eq!(s.histogram(4), vec![3, 2, 2, 1]); // np.histogram(a, 4)
    }

    #[test]
    fn missing_samples_are_counted_and_left_out() {
        let s = Stats::of(&[3.0, f32::NAN, 1.0, f32::INFINITY, 5.0, f32::NEG_INFINITY]);
        assert_eq!((s.count, s.missing), (6, 3));
        assert_eq!((s.min, s.max, s.mean), (1.0, 5.0, 3.0));
        assert_eq!(s.percentile(50.0), Some(3.0));
        assert_eq!(s.histogram(2), vec![1, 2]);
        let plain = Stats::of(&[3.0, 1.0, 5.0]);
        assert_eq!((plain.mean, plain.sigma), (s.mean, s.sigma));
    }

    #[test]
    fn no_finite_sample_has_no_figures() {
        let s = Stats::of(&[f32::NAN, f32::INFINITY]);
        assert_eq!((s.count, s.missing, s.finite()), (2, 2, 0));
        assert_eq!(s.percentile(50.0), None);
        assert_eq!(super::moments(&[f32::NAN]), None);
    }
}
