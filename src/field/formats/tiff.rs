//! TIFF stacks (`.tif`, `.tiff`; the `tiff` crate): each page (IFD) is one z slice, its
//! columns x and its rows y (row 0 first). Grayscale pages of 8, 16, 32 or 64-bit integers or
//! floats, all the same size and type. TIFF has no voxel size isoview trusts (ImageJ's
//! descriptions vary), so `spacing` comes from the scene (default 1).

use std::io::BufReader;

use glam::DVec3;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::ColorType;

use super::{Located, ReadOptions, Volume};
use crate::field::FieldError;

/// How many pages the header walk counts at most once the stack is over the cap: enough for
/// any real stack's count (and so the cap it needs), while a file of millions of tiny page
/// headers stops early; the refusal then says the count is a floor.
pub const MAX_PAGES_COUNTED: u64 = 1 << 16;

/// Added to the refusal when the walk stopped at [`MAX_PAGES_COUNTED`].
const MORE_PAGES: &str = "; the stack has more pages than that (isoview stopped counting them)";

pub fn read(err: &Located, opts: &ReadOptions) -> Result<Volume, FieldError> {
    let file = err.access.open(err.path).map_err(|e| err.io(&e))?;
    let tiff_err = |e: tiff::TiffError| err.bad(crate::field::error::one_line(&e.to_string()));
    let mut limits = Limits::default();
    limits.decoding_buffer_size = opts.limits.max_bytes as usize;
    limits.intermediate_buffer_size = opts.limits.max_bytes as usize;
    let mut dec = Decoder::new(BufReader::new(file)).map_err(tiff_err)?.with_limits(limits);
    let (w, h) = dec.dimensions().map_err(tiff_err)?;
    let color = dec.colortype().map_err(tiff_err)?;
    if !matches!(color, ColorType::Gray(_)) {
        return Err(err.bad(format!("page 0 is {color:?}; isoview reads grayscale stacks")));
    }
    // First pass, over the page headers only: every page the same, and the whole stack under
    // the cap before any page is decoded. Pages are checked against the cap as they are
    // counted; once past it the walk goes on counting (headers only, at most
    // MAX_PAGES_COUNTED pages; the tiff crate refuses a cyclic chain), so that the refusal
    // states the stack's real size and the cap it would need, not the count where the cap was
    // first passed.
    let mut pages = 1u64;
    let mut over_cap = false;
    let mut counted_all = true;
    loop {
        over_cap = over_cap || err.limits_check(&opts.limits, [w as u64, h as u64, pages]).is_err();
        if dec.dimensions().map_err(tiff_err)? != (w, h)
            || dec.colortype().map_err(tiff_err)? != color
        {
            return Err(err.bad(format!("page {} differs in size or type from page 0", pages - 1)));
        }
        if !dec.more_images() {
            break;
        }
        if over_cap && pages >= MAX_PAGES_COUNTED {
            counted_all = false;
            break;
        }
        dec.next_image().map_err(tiff_err)?;
        pages += 1;
    }
    // Over the cap, this is the refusal, with every page counted (or the floor, said so).
    let dims =
        super::payload::grid(err, [w as u64, h as u64, pages], &opts.limits).map_err(|e| {
            match counted_all {
                true => e,
                false => crate::field::limits::with_hint(e, MORE_PAGES),
            }
        })?;
    dec.seek_to_image(0).map_err(tiff_err)?;
    let mut values = Vec::with_capacity(dims.iter().product());
    for page in 0..pages {
        if page > 0 {
            dec.next_image().map_err(tiff_err)?;
        }
        match dec.read_image().map_err(tiff_err)? {
            DecodingResult::U8(v) => values.extend(v.iter().map(|&x| x as f32)),
            DecodingResult::U16(v) => values.extend(v.iter().map(|&x| x as f32)),
            DecodingResult::U32(v) => values.extend(v.iter().map(|&x| x as f32)),
            DecodingResult::U64(v) => values.extend(v.iter().map(|&x| x as f32)),
            DecodingResult::I8(v) => values.extend(v.iter().map(|&x| x as f32)),
            DecodingResult::I16(v) => values.extend(v.iter().map(|&x| x as f32)),
            DecodingResult::I32(v) => values.extend(v.iter().map(|&x| x as f32)),
            DecodingResult::I64(v) => values.extend(v.iter().map(|&x| x as f32)),
            DecodingResult::F32(v) => values.extend(v),
            DecodingResult::F64(v) => {
                for &x in &v {
                    let at = values.len();
                    values.push(crate::field::samples::narrow(x).map_err(|value| {
                        let what = crate::field::npy::path_str(err.path);
                        let dims = [w as usize, h as usize, pages as usize];
                        crate::field::samples::Overflow { at, value }.error(
                            what,
                            dims,
                            String::new(),
                        )
                    })?);
                }
            }
            _ => return Err(err.bad(format!("page {page}: a sample type isoview does not read"))),
        }
        if values.len() as u64 != w as u64 * h as u64 * (page + 1) {
            return Err(err.bad(format!("page {page} does not hold {w}x{h} samples")));
        }
    }
    let bits = match color {
        ColorType::Gray(b) => b,
        _ => 0,
    };
    Ok(Volume {
        dims,
        values,
        origin: DVec3::ZERO,
        spacing: opts.spacing.unwrap_or(DVec3::ONE),
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        dtype: format!("{bits}-bit gray"),
        data_file: None,
        sparse: None,
    })
}
