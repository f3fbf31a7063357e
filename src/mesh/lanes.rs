//! Four f64 lanes, each operated on with f64's own operations: what a row of cells computes
//! at once (`nets`), so that their long chains of divisions and square roots overlap and the
//! compiler can use vector instructions, while every lane's result stays the scalar
//! arithmetic's bit for bit (no fused or reordered operation: each `+`, `*`, `/` and `sqrt`
//! is the IEEE operation of each lane).

use std::ops::{Add, Div, Mul, Sub};

/// Lane count of [`F64x4`].
pub(crate) const LANES: usize = 4;

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct F64x4(pub [f64; LANES]);

impl F64x4 {
    #[inline(always)]
    pub fn splat(x: f64) -> Self {
        F64x4([x; LANES])
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        F64x4(self.0.map(f))
    }

    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        F64x4(std::array::from_fn(|i| f(self.0[i], o.0[i])))
    }

    #[inline(always)]
    pub fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }

    /// Per lane, `self < o`.
    #[inline(always)]
    pub fn lt(self, o: Self) -> [bool; LANES] {
        std::array::from_fn(|i| self.0[i] < o.0[i])
    }

    /// Per lane, `self > o`.
    #[inline(always)]
    pub fn gt(self, o: Self) -> [bool; LANES] {
        std::array::from_fn(|i| self.0[i] > o.0[i])
    }

    /// Per lane, whether it is finite.
    #[inline(always)]
    pub fn is_finite(self) -> [bool; LANES] {
        self.0.map(f64::is_finite)
    }

    /// The lanes rounded to f32.
    #[inline(always)]
    pub fn to_f32(self) -> [f32; LANES] {
        self.0.map(|x| x as f32)
    }
}

macro_rules! lanewise {
    ($trait:ident, $f:ident, $op:tt) => {
        impl $trait for F64x4 {
            type Output = F64x4;
            #[inline(always)]
            fn $f(self, o: F64x4) -> F64x4 {
                self.zip(o, |a, b| a $op b)
            }
        }
    };
}
lanewise!(Add, add, +);
lanewise!(Sub, sub, -);
lanewise!(Mul, mul, *);
lanewise!(Div, div, /);

/// Lane by lane `a && b`.
#[inline(always)]
pub(crate) fn and(a: [bool; LANES], b: [bool; LANES]) -> [bool; LANES] {
    std::array::from_fn(|i| a[i] & b[i])
}
