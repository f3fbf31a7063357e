//! The marching-squares case table, oriented, and the rule for its two ambiguous cases.
//!
//! ```text
//!   corner 3 ---- edge 2 ---- corner 2        corners counterclockwise from the lower left;
//!      |                         |            edge k joins corner k to corner k + 1 (mod 4);
//!    edge 3                    edge 1         case = sum of 2^k over the inside corners k.
//!      |                         |
//!   corner 0 ---- edge 0 ---- corner 1        v
//!                                             |
//!                                             +-- u
//! ```
//!
//! Every segment runs from the crossing where a counterclockwise walk around the cell leaves
//! the inside (an *exit*) to one where it comes back in (an *entry*), so the inside is on the
//! segment's left. In cases 5 and 10 (inside corners on one diagonal) there are two exits and two
//! entries: when the cell's centre is outside, each exit pairs with the entry just before it
//! (the inside corners are cut off separately); when it is inside, with the entry just after it
//! (the inside corners are joined through the centre).

use crate::scene::{Ambiguity, Inside};

/// Oriented segments `[from edge, to edge]` of each case (inside on the left). Cases 5 and 10
/// hold the *separated* variant (centre outside); [`JOINED`] holds the other.
pub const CASES: [&[[u8; 2]]; 16] = [
    &[],
    &[[0, 3]],
    &[[1, 0]],
    &[[1, 3]],
    &[[2, 1]],
    &[[0, 3], [2, 1]],
    &[[2, 0]],
    &[[2, 3]],
    &[[3, 2]],
    &[[0, 2]],
    &[[1, 0], [3, 2]],
    &[[1, 2]],
    &[[3, 1]],
    &[[0, 1]],
    &[[3, 0]],
    &[],
];

/// Cases 5 and 10 with their inside corners joined through the centre: `[case 5, case 10]`.
pub const JOINED: [[[u8; 2]; 2]; 2] = [[[0, 1], [2, 3]], [[1, 2], [3, 0]]];

/// The case index of a cell whose corner `k` is inside when `inside[k]`.
pub fn case_index(inside: [bool; 4]) -> usize {
    inside.iter().enumerate().map(|(k, &b)| usize::from(b) << k).sum()
}

/// Whether `case` is one of the two ambiguous cases (5, 10).
pub fn is_ambiguous(case: usize) -> bool {
    case == 5 || case == 10
}

/// The oriented segments of `case`; `centre_inside` picks the variant of cases 5 and 10.
pub fn segments(case: usize, centre_inside: bool) -> &'static [[u8; 2]] {
    match (case, centre_inside) {
        (5, true) => &JOINED[0],
        (10, true) => &JOINED[1],
        _ => CASES[case],
    }
}

/// Whether the centre of a cell in case 5 or 10 is inside, by `rule`. `corners` are the cell's
/// values counterclockwise from the lower left; `sample` evaluates the source at the centre
/// (called only for [`Ambiguity::Sample`]; None counts as the corner average).
pub fn centre_inside(
    rule: Ambiguity,
    corners: [f64; 4],
    sample: impl FnOnce() -> Option<f64>,
    isovalue: f64,
    inside: Inside,
) -> bool {
    let average = || 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
    match rule {
        Ambiguity::Average => inside.contains(average(), isovalue),
        Ambiguity::Sample => inside.contains(sample().unwrap_or_else(average), isovalue),
        Ambiguity::Saddle => {
            // The bilinear interpolant's value at its saddle point, relative to the isovalue:
            // (g0 g2 - g1 g3) / (g0 + g2 - g1 - g3) with g = value - isovalue. In cases 5 and 10
            // g0, g2 and g1, g3 lie on opposite sides of 0, so the denominator is not 0.
            let g = corners.map(|c| c - isovalue);
            let denominator = g[0] + g[2] - g[1] - g[3];
            if denominator == 0.0 {
                return inside.contains(average(), isovalue);
            }
            inside.contains((g[0] * g[2] - g[1] * g[3]) / denominator, 0.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table again, from the rule in the module docs.
    fn derived(case: usize, joined: bool) -> Vec<[u8; 2]> {
        let inside = |k: usize| case >> (k % 4) & 1 == 1;
        // Walking counterclockwise, edge k is an exit when corner k is inside and k + 1 is not.
        let exits: Vec<usize> = (0..4).filter(|&k| inside(k) && !inside(k + 1)).collect();
        let entries: Vec<usize> = (0..4).filter(|&k| !inside(k) && inside(k + 1)).collect();
        let mut out = Vec::new();
        for &x in &exits {
            let entry = if joined {
                (1..4).map(|d| (x + d) % 4).find(|e| entries.contains(e))
            } else {
                (1..4).map(|d| (x + 4 - d) % 4).find(|e| entries.contains(e))
            };
            out.push([x as u8, entry.unwrap() as u8]);
        }
        out
    }

    #[test]
    fn table_follows_the_orientation_rule() {
        for case in 0..16 {
            assert_eq!(segments(case, false), derived(case, false).as_slice(), "case {case}");
            if is_ambiguous(case) {
                assert_eq!(segments(case, true), derived(case, true).as_slice(), "case {case}");
            } else {
                assert_eq!(segments(case, true), segments(case, false));
            }
        }
    }

    #[test]
    fn ambiguity_rules() {
        // Case 5 below 0: corners 0 and 2 inside. Mean 0.1 (outside), saddle value
        // (-1 * -0.6 - 0.9 * 1.1) / (-1.6 - 2.0) = 0.108 (outside).
        let c = [-1.0, 0.9, -0.6, 1.1];
        let b = Inside::Below;
        assert!(!centre_inside(Ambiguity::Average, c, || None, 0.0, b));
        assert!(!centre_inside(Ambiguity::Saddle, c, || None, 0.0, b));
        assert!(centre_inside(Ambiguity::Sample, c, || Some(-0.2), 0.0, b));
        // Mean exactly at the isovalue: equal is outside.
        assert!(!centre_inside(Ambiguity::Average, [-1.0, 1.0, -1.0, 1.0], || None, 0.0, b));
        // Mean 0.075 (outside), saddle value (1 - 0.42) / (-2 - 2.3) = -0.135 (inside).
        let c = [-1.0, 0.2, -1.0, 2.1];
        assert!(!centre_inside(Ambiguity::Average, c, || None, 0.0, b));
        assert!(centre_inside(Ambiguity::Saddle, c, || None, 0.0, b));
        assert_eq!(case_index([true, false, true, false]), 5);
    }
}
