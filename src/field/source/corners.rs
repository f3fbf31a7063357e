//! `source = "corners"`: one cell given by its 8 corner values (`v000, v100, v010, v110, v001,
//! v101, v011, v111`, vXYZ the corner at x = X, y = Y, z = Z), over `bounds` (default the unit
//! cube). It is the trilinear interpolant of those values, so it can be evaluated anywhere.

use super::params::{Need, Params};
use super::{fill, FieldSource, Info, Parsed, PointField, Supports};
use crate::field::interpolant::{Kernel, Trilinear};
use crate::field::Grid;
use crate::vocab::Bounds;

pub(super) const INFO: Info = Info {
    name: "corners",
    keys: &["values"],
    own_box: None,
    supports: Supports { point: true, time: false },
};

pub(super) fn parse<P: Params>(p: &P) -> Result<Parsed, P::Error> {
    let values = p.numbers8(
        "values",
        Need::Required("8 corner values v000, v100, v010, v110, v001, v101, v011, v111"),
    )?;
    Ok(Parsed {
        source: FieldSource::Corners(values),
        resolution: [2, 2, 2],
        bounds: None,
        placement: None,
    })
}

/// The grid's points sample the interpolant: the one trilinear implementation, the same as
/// [`point`] (on a 2x2x2 grid, exactly the corner values: `trilerp` is exact at 0 and 1).
pub(super) fn sample(
    v: &[f64; 8],
    grid: &Grid,
) -> Result<Vec<f32>, crate::field::samples::Overflow> {
    let (lo, size) = (grid.min, grid.max - grid.min);
    fill(grid, |p| Trilinear::value(v, (p - lo) / size))
}

pub(super) fn point<'a>(v: &'a [f64; 8], bounds: &Bounds) -> PointField<'a> {
    let (lo, size) = (bounds.min, bounds.max - bounds.min);
    PointField { eval: Box::new(move |p| Trilinear::value(v, (p - lo) / size)), lipschitz: None }
}

pub(super) fn describe(v: &[f64; 8]) -> String {
    format!("corners [{}]", v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "))
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    fn grid(dims: [usize; 3], bounds: Bounds) -> Grid {
        Grid { dims, min: bounds.min, max: bounds.max, values: Vec::new() }
    }

    /// One interpolant for the grid and for slices (#16): the samples are the point
    /// evaluation, bit for bit, and a 2x2x2 grid holds the corner values themselves.
    #[test]
    fn samples_are_the_point_evaluation_and_the_corners_exactly() {
        let cells = [
            [-0.8, 1.0, 0.6, -0.6, 0.7, 1.1, 0.9, 1.3], // scenes/cell-face-ambiguous.toml
            [-1.0, 0.3, 0.25, 0.35, 0.3, 0.25, 0.2, -0.9], // scenes/cell-tunnel.toml
            [1e20, 1.0, -3.0, 1e-20, 0.1, -0.7, 2.5, -1e10],
        ];
        let boxes = [
            Bounds::UNIT,
            Bounds { min: DVec3::new(-0.3, 0.1, 2.0), max: DVec3::new(0.7, 1.9, 5.0) },
        ];
        for v in &cells {
            let coarse = sample(v, &grid([2, 2, 2], Bounds::UNIT)).unwrap();
            assert_eq!(coarse, v.map(|x| x as f32), "{v:?}");
            for b in boxes {
                let g = grid([4, 3, 5], b);
                let values = sample(v, &g).unwrap();
                let point = point(v, &b);
                for k in 0..5 {
                    for j in 0..3 {
                        for i in 0..4 {
                            let want = (point.eval)(g.point(i, j, k)) as f32;
                            assert_eq!(values[g.index(i, j, k)].to_bits(), want.to_bits());
                        }
                    }
                }
            }
        }
    }
}
