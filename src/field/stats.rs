//! Summary statistics of a grid's samples, for `isoview stats` and for isovalues picked from
//! the data (`isovalue_sigma`, `isovalue_percentile`).
//!
//! - mean and σ over all samples, σ the population standard deviation (divided by n, as
//!   NumPy's `std` and the cryo-EM "rms" of mrcfile and ChimeraX), both summed in f64;
//! - percentiles by NumPy's default (`method = "linear"`): for p in [0, 100] the sorted
//!   samples' value at fractional rank `p / 100 * (n - 1)`, interpolated linearly between
//!   the two neighbouring ranks.

/// Statistics of a set of samples.
#[derive(Clone, Debug)]
pub struct Stats {
    pub count: usize,
    pub min: f64,
    pub max: f64,
    pub mean: f64,
    /// Population standard deviation.
    pub sigma: f64,
    sorted: Vec<f32>,
}

impl Stats {
    /// The statistics of `values` (finite, not empty: a sampled grid's).
    pub fn of(values: &[f32]) -> Stats {
        let count = values.len();
        let (mean, sigma) = moments(values);
        let mut sorted = values.to_vec();
        sorted.sort_unstable_by(f32::total_cmp);
        let (min, max) = match (sorted.first(), sorted.last()) {
            (Some(&a), Some(&b)) => (a as f64, b as f64),
            _ => (0.0, 0.0),
        };
        Stats { count, min, max, mean, sigma, sorted }
    }

    /// The `p`-th percentile (0..=100), NumPy's linear rule.
    pub fn percentile(&self, p: f64) -> f64 {
        let s = &self.sorted;
        if s.is_empty() {
            return 0.0;
        }
        let rank = (p.clamp(0.0, 100.0) / 100.0) * (s.len() - 1) as f64;
        let lo = rank.floor() as usize;
        let hi = (lo + 1).min(s.len() - 1);
        let (a, b) = (s[lo] as f64, s[hi] as f64);
        a + (b - a) * (rank - lo as f64)
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

/// Mean and population σ of `values`, without the sorted copy [`Stats::of`] keeps.
pub fn moments(values: &[f32]) -> (f64, f64) {
    let n = values.len().max(1) as f64;
    let mean = values.iter().map(|&v| v as f64).sum::<f64>() / n;
    let var = values.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt())
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
            assert!((s.percentile(p) - want).abs() < 1e-12, "p{p}: {}", s.percentile(p));
        }
        assert_eq!(s.mean, 3.875);
        assert!((s.sigma - 2.570_870_475_150_391_7).abs() < 1e-12, "{}", s.sigma);
        assert_eq!((s.min, s.max), (1.0, 9.0));
        assert_eq!(s.histogram(4), vec![3, 2, 2, 1]); // np.histogram(a, 4)
    }
}
