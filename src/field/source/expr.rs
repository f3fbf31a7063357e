//! `source = "expr"`: an `expression` over `x`, `y`, `z` (world coordinates) and `t` (the
//! time), evaluated at the grid points (`resolution`). The evaluator is
//! [`crate::field::ExprSource`] (`field/expr.rs`, the `exmex` crate).

use glam::DVec3;

use super::params::{self, Need, Params};
use super::{fill, FieldSource, Info, Parsed, PointField, Supports};
use crate::field::samples::check_finite;
use crate::field::{ExprSource, FieldError, Grid, NanPolicy};

pub(super) const INFO: Info = Info {
    name: "expr",
    keys: &["expression", "resolution"],
    own_box: None,
    supports: Supports { point: true, time: true },
};

pub(super) fn parse<P: Params>(p: &P) -> Result<Parsed, P::Error> {
    let text = p.string("expression", Need::Required("e.g. \"sin(3*x)*cos(3*y) + z - 0.2*t\""))?;
    let expr = ExprSource::parse(&text).map_err(|e| match e {
        FieldError::Expr { message, .. } => p.value_error("expression", message),
        other => p.data_error("expression", other),
    })?;
    let resolution = params::resolution(p)?;
    Ok(Parsed { source: FieldSource::Expr(expr), resolution, bounds: None, placement: None })
}

/// The samples at `time`; a non-finite one, which `nan` refuses, is reported with its world
/// position.
pub(super) fn sample(
    e: &ExprSource,
    grid: &Grid,
    time: f64,
    nan: NanPolicy,
) -> Result<Vec<f32>, FieldError> {
    let spacing = grid.spacing();
    // Numbers in their short form (`--time 1e308` printed 309 digits), the text cut and escaped.
    let n = crate::vocab::echo_number::<f64>;
    let what = || format!("expression \"{}\" at t = {}", crate::vocab::echo(&e.text), n(time));
    let at = |[i, j, k]: [usize; 3]| {
        let p = grid.min + spacing * DVec3::new(i as f64, j as f64, k as f64);
        format!(" (x = {}, y = {}, z = {})", n(p.x), n(p.y), n(p.z))
    };
    let values = fill(grid, |p| e.eval(p, time)).map_err(|o| {
        o.error(what(), grid.dims, at(crate::field::samples::grid_index(o.at, grid.dims)))
    })?;
    check_finite(&values, grid.dims, nan, what, at)?;
    Ok(values)
}

pub(super) fn point(e: &ExprSource, time: f64) -> PointField<'_> {
    PointField { eval: Box::new(move |p| e.eval(p, time)), lipschitz: None }
}

pub(super) fn describe(e: &ExprSource) -> String {
    format!("expr \"{}\"", e.text)
}
