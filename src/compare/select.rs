//! The k-th smallest of a stream of floats without holding the stream: exact nearest-rank
//! percentiles (relative p99 per channel, FLIP p50/p95/p99/max) for the band-by-band
//! comparison, which sees every value once per pass and cannot keep them all.
//!
//! Each value becomes an integer key whose order is `total_cmp`'s (the sign bit flipped for
//! positives, every bit for negatives). A pass either counts the next 16 bits of the keys
//! that share the digits found so far (a 65 536-bucket histogram: 512 KiB), or, once at most
//! [`COLLECT`] keys remain candidates, keeps those keys and picks the k-th. So f32 takes at
//! most two passes after the first, f64 at most four, and usually one; none when the keys in
//! the chosen bucket are all equal (each bucket's smallest and largest key are kept):
//!
//! ```text
//!   pass 1: histogram of the top 16 bits -> bucket holding rank k, rank within it
//!   pass 2: bucket small? keep its keys, sort, done : histogram of the next 16 bits ...
//! ```

/// Candidates kept in memory (8 bytes each) instead of another histogram pass.
pub const COLLECT: u64 = 1 << 18;

const DIGIT: u32 = 16;

/// One rank being searched for.
#[derive(Clone, Debug)]
pub struct Select {
    /// Key width: 32 or 64.
    bits: u32,
    /// The leading `known` bits of the answer's key.
    prefix: u64,
    known: u32,
    /// 0-based rank among the keys that start with `prefix`.
    rank: u64,
    /// Keys starting with `prefix` (unknown before the first pass).
    candidates: Option<u64>,
    hist: Vec<u64>,
    /// Smallest and largest key counted in each bucket: a bucket whose keys are all equal
    /// (all zeros, typically) gives the answer without another pass.
    lo: Vec<u64>,
    hi: Vec<u64>,
    kept: Vec<u64>,
    answer: Option<u64>,
}

/// The order-preserving key of an f64.
pub fn key64(v: f64) -> u64 {
    let b = v.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | 1 << 63
    }
}

fn unkey64(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// The order-preserving key of an f32 (in the low 32 bits).
pub fn key32(v: f32) -> u64 {
    let b = v.to_bits();
    u64::from(if b >> 31 == 1 { !b } else { b | 1 << 31 })
}

fn unkey32(k: u64) -> f32 {
    let k = k as u32;
    f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k })
}

impl Select {
    /// The `rank`-th smallest (0-based) of 64-bit keys ([`key64`]) or 32-bit ones ([`key32`]).
    pub fn new(bits: u32, rank: u64) -> Select {
        Select {
            bits,
            prefix: 0,
            known: 0,
            rank,
            candidates: None,
            hist: Vec::new(),
            lo: Vec::new(),
            hi: Vec::new(),
            kept: Vec::new(),
            answer: None,
        }
    }

    /// Sets the rank searched for (before the first [`Select::end`], for a count known only
    /// once the first pass is over).
    pub fn set_rank(&mut self, rank: u64) {
        self.rank = rank;
    }

    /// Whether the answer is known (no more passes needed for it).
    pub fn done(&self) -> bool {
        self.answer.is_some()
    }

    fn collecting(&self) -> bool {
        self.candidates.is_some_and(|n| n <= COLLECT)
    }

    /// Readies the next pass.
    pub fn begin(&mut self) {
        if self.done() {
            return;
        }
        if self.collecting() {
            self.kept = Vec::with_capacity(self.candidates.unwrap_or(0) as usize);
        } else {
            self.hist = vec![0; 1 << DIGIT];
            self.lo = vec![u64::MAX; 1 << DIGIT];
            self.hi = vec![0; 1 << DIGIT];
        }
    }

    /// One value of the stream (its key).
    #[inline]
    pub fn offer(&mut self, key: u64) {
        if self.answer.is_some() {
            return;
        }
        if self.known > 0 && key >> (self.bits - self.known) != self.prefix {
            return;
        }
        if self.collecting() {
            self.kept.push(key);
        } else {
            let shift = self.bits - self.known - DIGIT;
            let d = ((key >> shift) & 0xffff) as usize;
            self.hist[d] += 1;
            self.lo[d] = self.lo[d].min(key);
            self.hi[d] = self.hi[d].max(key);
        }
    }

    /// Ends a pass. `Err` when the stream offered fewer keys than the rank needs (the stream
    /// changed between passes).
    pub fn end(&mut self) -> Result<(), String> {
        if self.done() {
            return Ok(());
        }
        if self.collecting() {
            let mut kept = std::mem::take(&mut self.kept);
            let r = self.rank as usize;
            if r >= kept.len() {
                return Err("a percentile's values changed between passes".into());
            }
            let (_, k, _) = kept.select_nth_unstable(r);
            self.answer = Some(*k);
            return Ok(());
        }
        let hist = std::mem::take(&mut self.hist);
        let (lo, hi) = (std::mem::take(&mut self.lo), std::mem::take(&mut self.hi));
        let mut below = 0u64;
        for (digit, &count) in hist.iter().enumerate() {
            if self.rank < below + count {
                self.rank -= below;
                self.prefix = self.prefix << DIGIT | digit as u64;
                self.known += DIGIT;
                self.candidates = Some(count);
                if self.known == self.bits {
                    self.answer = Some(self.prefix);
                } else if lo[digit] == hi[digit] {
                    self.answer = Some(lo[digit]);
                }
                return Ok(());
            }
            below += count;
        }
        Err("a percentile's values changed between passes".into())
    }

    /// The answer as an f64 (64-bit keys).
    pub fn f64(&self) -> Option<f64> {
        self.answer.map(unkey64)
    }

    /// The answer as an f32 (32-bit keys).
    pub fn f32(&self) -> Option<f32> {
        self.answer.map(unkey32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs passes over `values` until the selection is done; returns the answer and passes.
    fn run64(values: &[f64], rank: u64) -> (f64, usize) {
        let mut s = Select::new(64, rank);
        let mut passes = 0;
        while !s.done() {
            s.begin();
            values.iter().for_each(|&v| s.offer(key64(v)));
            s.end().unwrap();
            passes += 1;
        }
        (s.f64().unwrap(), passes)
    }

    #[test]
    fn keys_keep_total_order() {
        let v = [f64::NEG_INFINITY, -2.0, -0.0, 0.0, 1e-300, 0.5, 2.0, f64::INFINITY];
        for w in v.windows(2) {
            assert!(key64(w[0]) < key64(w[1]), "{w:?}");
            assert_eq!(unkey64(key64(w[0])).to_bits(), w[0].to_bits());
        }
        for x in [-1.5f32, -0.0, 0.0, 0.25, f32::INFINITY] {
            assert_eq!(unkey32(key32(x)).to_bits(), x.to_bits());
        }
        assert!(key32(-1.0) < key32(0.0) && key32(0.0) < key32(1.0));
    }

    #[test]
    fn exact_ranks_small_and_in_one_huge_bucket() {
        let mut v: Vec<f64> = (0..1000).map(|i| ((i * 7919) % 1000) as f64 / 997.0).collect();
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        for r in [0, 1, 500, 989, 999] {
            assert_eq!(run64(&v, r).0, sorted[r as usize]);
        }
        // More candidates than COLLECT in every 16-bit bucket: all four digits by histogram.
        v = vec![0.75; COLLECT as usize + 10];
        v[3] = 0.75 + f64::EPSILON;
        v[4] = 0.75 + 2.0 * f64::EPSILON;
        let (x, passes) = run64(&v, COLLECT + 9);
        assert_eq!((x, passes), (0.75 + 2.0 * f64::EPSILON, 4));
        let (x, passes) = run64(&v, COLLECT + 8);
        assert_eq!((x, passes), (0.75 + f64::EPSILON, 4));
        let (x, passes) = run64(&v, 0);
        assert_eq!((x, passes), (0.75, 4));
        // All equal: found in the first pass.
        assert_eq!(run64(&[0.0; 1000], 989), (0.0, 1));
    }

    #[test]
    fn a_stream_that_shrinks_is_an_error() {
        let mut s = Select::new(32, 5);
        s.begin();
        (0..3).for_each(|i| s.offer(key32(i as f32)));
        assert!(s.end().is_err());
    }
}
