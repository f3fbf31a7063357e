//! `source = "corners"`: one cell given by its 8 corner values (`v000, v100, v010, v110, v001,
//! v101, v011, v111`, vXYZ the corner at x = X, y = Y, z = Z), over `bounds` (default the unit
//! cube). It is the trilinear interpolant of those values, so it can be evaluated anywhere.

use glam::DVec3;

use super::params::{Need, Params};
use super::{fill, FieldSource, Info, Parsed, PointField, Supports};
use crate::field::trilinear::trilerp;
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
    Ok(Parsed { source: FieldSource::Corners(values), resolution: [2, 2, 2], bounds: None })
}

/// The grid's points sample the interpolant (on a 2x2x2 grid: the corner values themselves).
pub(super) fn sample(v: &[f64; 8], grid: &Grid) -> Vec<f32> {
    let (lo, size) = (grid.min, grid.max - grid.min);
    fill(grid, |p| trilinear(v, (p - lo) / size))
}

pub(super) fn point<'a>(v: &'a [f64; 8], bounds: &Bounds) -> PointField<'a> {
    let (lo, size) = (bounds.min, bounds.max - bounds.min);
    PointField { eval: Box::new(move |p| trilerp(v, (p - lo) / size)), lipschitz: None }
}

pub(super) fn describe(v: &[f64; 8]) -> String {
    format!("corners [{}]", v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "))
}

/// The trilinear interpolant of corner values `v` (vXYZ order) at unit-cube coordinates `u`.
fn trilinear(v: &[f64; 8], u: DVec3) -> f64 {
    let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
    let x00 = lerp(v[0], v[1], u.x);
    let x10 = lerp(v[2], v[3], u.x);
    let x01 = lerp(v[4], v[5], u.x);
    let x11 = lerp(v[6], v[7], u.x);
    lerp(lerp(x00, x10, u.y), lerp(x01, x11, u.y), u.z)
}
