//! `source = "raw"`: a headerless binary file (`path`, `dims`, `dtype`, `endian`), x varying
//! fastest. The reader is [`crate::field::RawSource`] (`field/raw.rs`); the file's length is
//! checked against `dims` and `dtype` at load time.

use super::params::{self, Need, Params};
use super::{check_file_dims, FieldSource, Info, Parsed, Supports};
use crate::field::{Endian, FieldError, Grid, GridLimits, RawSource, SampleType};

pub(super) const INFO: Info = Info {
    name: "raw",
    keys: &["path", "dims", "dtype", "endian", "residency"],
    own_box: None,
    supports: Supports { point: false, time: false },
};

pub(super) fn parse<P: Params>(p: &P) -> Result<Parsed, P::Error> {
    let path = params::data_path(p)?;
    let dims = p.points3("dims", Need::Required("grid points along x, y, z, e.g. [64, 64, 64]"))?;
    let types = SampleType::ALL.map(|ty| (ty.name(), ty));
    let dtype =
        p.choice("dtype", Need::Required("\"u8\", \"u16\", \"i16\", \"f32\" or \"f64\""), &types)?;
    let endians = [("little", Endian::Little), ("big", Endian::Big)];
    let endian = p.choice("endian", Need::Or(Endian::Little), &endians)?;
    let raw = RawSource { path, dims, dtype, endian, access: p.access().clone() };
    raw.check(p.limits()).map_err(|e| match e {
        FieldError::Io { .. } => p.data_error("path", e),
        // Too large, truncated or too long: the dims are the likeliest mistake.
        _ => p.data_error("dims", crate::field::limits::with_residency_hint(e)),
    })?;
    Ok(Parsed { source: FieldSource::Raw(raw), resolution: dims, bounds: None, placement: None })
}

pub(super) fn sample(
    r: &RawSource,
    grid: &Grid,
    limits: &GridLimits,
) -> Result<Vec<f32>, FieldError> {
    check_file_dims(r.dims, grid)?;
    r.read(limits)
}

pub(super) fn describe(r: &RawSource) -> String {
    format!("raw {} {} {}-endian", r.file_name(), r.dtype.name(), r.endian.name())
}
