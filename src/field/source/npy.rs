//! `source = "npy"`: a `.npy` file (`path`, relative to the scene file); the grid's dims are
//! the array's shape. The reader is [`crate::field::NpySource`] (`field/npy.rs`); its header and
//! length are checked at load time, the samples read when the grid is sampled.

use super::params::{self, Params};
use super::{check_file_dims, FieldSource, Info, Parsed, Supports};
use crate::field::samples::StorageOrder;
use crate::field::{FieldError, Grid, GridLimits, NpySource};

pub(super) const INFO: Info = Info {
    name: "npy",
    keys: &["path", "residency"],
    own_box: None,
    supports: Supports { point: false, time: false },
};

pub(super) fn parse<P: Params>(p: &P) -> Result<Parsed, P::Error> {
    let path = params::data_path(p)?;
    let npy = NpySource::open(&path, p.limits(), p.access())
        .map_err(|e| p.data_error("path", crate::field::limits::with_residency_hint(e)))?;
    let resolution = npy.dims;
    Ok(Parsed { source: FieldSource::Npy(npy), resolution, bounds: None, placement: None })
}

pub(super) fn sample(
    n: &NpySource,
    grid: &Grid,
    limits: &GridLimits,
) -> Result<Vec<f32>, FieldError> {
    check_file_dims(n.dims, grid)?;
    n.read(limits)
}

pub(super) fn describe(n: &NpySource) -> String {
    format!(
        "npy {} {} {}-order",
        crate::field::raw::file_name(&n.path),
        n.descr,
        if n.order == StorageOrder::ZFastest { "C" } else { "Fortran" }
    )
}
