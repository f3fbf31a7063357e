//! OpenVDB `.vdb` files, read by the OpenVDB library itself (`crates/openvdb`, behind the
//! default `openvdb` feature): every compression, half floats and grid class as OpenVDB reads
//! them.
//!
//! The read runs in a child process ([`isoview_openvdb::isolated`]) under limits of memory
//! and time: OpenVDB trusts its input (a flipped byte in a metadata length made it allocate
//! 17 GB), so a malformed file is one line here, never a crash, a hang or the machine's
//! memory. The child opens the file with delayed loading off (a stream, never a mapping a
//! truncation could turn into SIGBUS), picks the grid (`grid = "NAME"`, else the only float
//! or double grid), reads its tree and samples its active-voxel index bounding box, under the
//! memory cap, into the reply.
//!
//! Geometry: OpenVDB's voxel centres (integer index coordinates) are the grid points; the box
//! is the active-voxel bounding box, placed by the grid's linear transform (world =
//! `[i j k 1] * M`, rows of `M` the index axes' steps). A non-linear map (frustum) is refused
//! unless `bounds` places the index box; shear is refused by the common placement check.

use super::{Located, ReadOptions, Volume};
use crate::field::FieldError;

/// The most grids a file may list (each is named in messages).
pub const MAX_GRIDS: usize = 4096;

/// Grid names are cut to this many bytes in messages.
const NAME_BYTES: usize = 64;

/// How many grid names a message lists.
const NAMES_LISTED: usize = 8;

#[cfg(not(feature = "openvdb"))]
pub(super) fn read(err: &Located, _opts: &ReadOptions) -> Result<Volume, FieldError> {
    Err(err.bad(
        "this isoview was built without OpenVDB (cargo --no-default-features); build it with \
         the default `openvdb` feature (./x installs libopenvdb-dev libboost-dev libtbb-dev)",
    ))
}

/// `"a", "b", "c" and 5 more`: the names for a message, bounded in count and length.
pub(super) fn list_names<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let all: Vec<&str> = names.collect();
    let mut shown: Vec<String> =
        all.iter().take(NAMES_LISTED).map(|n| format!("\"{}\"", short(n))).collect();
    if all.len() > NAMES_LISTED {
        shown.push(format!("{} more", all.len() - NAMES_LISTED));
    }
    shown.join(", ")
}

/// A grid name for messages: escaped, at most [`NAME_BYTES`] characters.
pub(super) fn short(name: &str) -> String {
    let escaped: String = name.escape_default().collect();
    match escaped.char_indices().nth(NAME_BYTES) {
        Some((i, _)) => format!("{}...", &escaped[..i]),
        None => escaped,
    }
}

/// Which grid of a file to read: `wanted` by name, else the only scalar one. `grids` holds
/// each grid's name and whether it is scalar (float or double) and its type name.
pub(super) fn select(
    grids: &[(String, String)],
    wanted: Option<&str>,
    scalar: &dyn Fn(&str) -> bool,
    what: &str,
) -> Result<usize, String> {
    if grids.len() > MAX_GRIDS {
        return Err(format!("{} grids, over isoview's limit of {MAX_GRIDS}", grids.len()));
    }
    let names = || grids.iter().map(|(n, _)| n.as_str());
    match wanted {
        Some(w) => {
            let Some(i) = grids.iter().position(|(n, _)| n == w) else {
                return Err(format!(
                    "no grid named \"{}\" (the file's grids: {})",
                    short(w),
                    if grids.is_empty() { "none".into() } else { list_names(names()) }
                ));
            };
            if !scalar(&grids[i].1) {
                return Err(format!(
                    "grid \"{}\" holds {} values; isoview reads {what} grids",
                    short(w),
                    short(&grids[i].1)
                ));
            }
            Ok(i)
        }
        None => {
            let found: Vec<usize> = (0..grids.len()).filter(|&i| scalar(&grids[i].1)).collect();
            match found[..] {
                [i] => Ok(i),
                [] => Err(format!(
                    "no {what} grid (the file's grids: {})",
                    if grids.is_empty() {
                        "none".to_string()
                    } else {
                        let typed: Vec<String> = grids
                            .iter()
                            .take(NAMES_LISTED)
                            .map(|(n, t)| format!("\"{}\" ({})", short(n), short(t)))
                            .collect();
                        let more = grids.len().saturating_sub(NAMES_LISTED);
                        let more =
                            if more > 0 { format!(" and {more} more") } else { String::new() };
                        format!("{}{more}", typed.join(", "))
                    }
                )),
                _ => Err(format!(
                    "{} {what} grids ({}); pick one with [field] grid = \"NAME\"",
                    found.len(),
                    list_names(found.iter().map(|&i| grids[i].0.as_str()))
                )),
            }
        }
    }
}

/// The grid points of an inclusive index box, or why there are none.
pub(super) fn box_dims(min: [i32; 3], max: [i32; 3], name: &str) -> Result<[u64; 3], String> {
    if (0..3).any(|k| min[k] > max[k]) {
        return Err(format!("grid \"{}\" has no active voxels", short(name)));
    }
    Ok([0, 1, 2].map(|k| (i64::from(max[k]) - i64::from(min[k]) + 1) as u64))
}

/// A placed grid's `Volume` from its index box and a linear map: `columns[k]` the world step
/// of index axis k, `translation` the world position of index (0, 0, 0).
pub(super) fn placed(
    err: &Located,
    dims: [u64; 3],
    min: [i32; 3],
    columns: [glam::DVec3; 3],
    translation: glam::DVec3,
    values: Vec<f32>,
    dtype: String,
) -> Result<Volume, FieldError> {
    let [i, j, k] = min.map(f64::from);
    let origin = translation + columns[0] * i + columns[1] * j + columns[2] * k;
    let mut v = Volume {
        dims: dims.map(|d| d as usize),
        values,
        origin: err.finite("the transform's image of the box's first voxel", origin)?,
        spacing: glam::DVec3::ONE,
        axes: [glam::DVec3::X, glam::DVec3::Y, glam::DVec3::Z],
        dtype,
        data_file: None,
    };
    v.set_axes(columns, "the grid's transform", err)?;
    Ok(v)
}

#[cfg(feature = "openvdb")]
pub(super) use with_library::read;

#[cfg(feature = "openvdb")]
mod with_library {
    use std::time::Duration;

    use glam::DVec3;
    use isoview_openvdb as ovdb;

    use super::{box_dims, placed, select, short, Located, ReadOptions, Volume};
    use crate::field::{FieldError, GRID_CAP_ENV};

    /// The child's reply, in its own little format: a tag byte, then the fields.
    const OK: u8 = b'O';
    const BAD: u8 = b'E';
    const OVER_CAP: u8 = b'C';

    /// The child's address space for a grid cap of `cap` bytes: the tree (at most about the
    /// box's dense size), the samples and the library.
    fn read_limit(cap: u64) -> u64 {
        cap.saturating_mul(3).saturating_add(2 << 30)
    }

    pub(crate) fn read(err: &Located, opts: &ReadOptions) -> Result<Volume, FieldError> {
        // The file is opened here first, as every reader's is (missing file, a FIFO, serve's
        // folders), and OpenVDB opens it by name in the child.
        drop(err.access.open(err.path).map_err(|e| err.io(&e))?);
        let cap = opts.limits.max_bytes;
        let limits = ovdb::Limits {
            address_space: read_limit(cap),
            cpu_seconds: 600,
            wall: Duration::from_secs(1200),
            max_reply: cap.saturating_add(1 << 20),
        };
        let path = err.path.to_path_buf();
        let wanted = opts.grid.clone();
        let reply = ovdb::isolated(limits, move || child(&path, wanted.as_deref(), cap))
            .map_err(|e| err.bad(e.to_string()))?;
        parse(err, opts, reply.bytes())
    }

    /// What the child does: open, pick, read, sample, encode.
    fn child(path: &std::path::Path, wanted: Option<&str>, cap: u64) -> Result<Vec<u8>, String> {
        let bad = |m: String| {
            let mut r = vec![BAD];
            r.extend_from_slice(m.as_bytes());
            Ok(r)
        };
        let mut file = match ovdb::File::open(path) {
            Ok(f) => f,
            Err(e) => return bad(e.to_string()),
        };
        let grids: Vec<(String, String)> =
            file.grids().iter().map(|g| (g.name.clone(), g.value_type.clone())).collect();
        let scalar = |t: &str| t == "float" || t == "double";
        let index = match select(&grids, wanted, &scalar, "float or double") {
            Ok(i) => i,
            Err(m) => return bad(m),
        };
        let name = grids[index].0.clone();
        let grid = match file.read(index) {
            Ok(g) => g,
            Err(e) => return bad(format!("grid \"{}\": {e}", short(&name))),
        };
        let info = &grid.info;
        let dims = match box_dims(info.bbox.0, info.bbox.1, &name) {
            Ok(d) => d,
            Err(m) => return bad(m),
        };
        let count = dims.iter().try_fold(1u64, |a, &d| a.checked_mul(d));
        if count.map_or(true, |n| n.saturating_mul(4) > cap) {
            let mut r = vec![OVER_CAP];
            for d in dims {
                r.extend_from_slice(&d.to_le_bytes());
            }
            return Ok(r);
        }
        let count = count.unwrap_or(0) as usize;
        let mut r = Vec::with_capacity(count * 4 + 1024);
        r.push(OK);
        put_str(&mut r, &name);
        r.push(info.linear as u8);
        put_str(&mut r, &info.map_type);
        for row in info.rows {
            for v in row {
                r.extend_from_slice(&v.to_le_bytes());
            }
        }
        for v in info.bbox.0 {
            r.extend_from_slice(&v.to_le_bytes());
        }
        for d in dims {
            r.extend_from_slice(&d.to_le_bytes());
        }
        r.extend_from_slice(&info.background.to_le_bytes());
        r.extend_from_slice(&info.class.to_le_bytes());
        r.push(info.double as u8);
        r.push(info.half as u8);
        r.extend_from_slice(&info.active_voxels.to_le_bytes());
        r.extend_from_slice(&info.leaf_count.to_le_bytes());
        // The box's values, a slab of z layers at a time straight into the reply: the child
        // holds one copy of the samples, not two.
        let layer = (dims[0] * dims[1]) as usize;
        let per_slab = ((16usize << 20) / layer.max(1)).max(1) as u64;
        let mut slab = Vec::new();
        let mut z = 0u64;
        while z < dims[2] {
            let nz = per_slab.min(dims[2] - z);
            slab.resize(layer * nz as usize, 0f32);
            let min = [info.bbox.0[0], info.bbox.0[1], info.bbox.0[2] + z as i32];
            if let Err(e) = grid.sample(min, [dims[0], dims[1], nz], &mut slab) {
                return bad(format!("grid \"{}\": {e}", short(&name)));
            }
            for v in &slab {
                r.extend_from_slice(&v.to_le_bytes());
            }
            z += nz;
        }
        Ok(r)
    }

    fn put_str(r: &mut Vec<u8>, s: &str) {
        r.extend_from_slice(&(s.len() as u32).to_le_bytes());
        r.extend_from_slice(s.as_bytes());
    }

    /// Reads the child's reply (written by [`child`], so a short one is a bug, said as such).
    struct Cursor<'a>(&'a [u8]);

    impl Cursor<'_> {
        fn take(&mut self, n: usize) -> Result<&[u8], String> {
            if self.0.len() < n {
                return Err("the reader's reply is cut short".into());
            }
            let (a, b) = self.0.split_at(n);
            self.0 = b;
            Ok(a)
        }
        fn u8(&mut self) -> Result<u8, String> {
            Ok(self.take(1)?[0])
        }
        fn u32(&mut self) -> Result<u32, String> {
            Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap_or_default()))
        }
        fn i32(&mut self) -> Result<i32, String> {
            Ok(i32::from_le_bytes(self.take(4)?.try_into().unwrap_or_default()))
        }
        fn u64(&mut self) -> Result<u64, String> {
            Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap_or_default()))
        }
        fn f64(&mut self) -> Result<f64, String> {
            Ok(f64::from_le_bytes(self.take(8)?.try_into().unwrap_or_default()))
        }
        fn str(&mut self) -> Result<String, String> {
            let n = self.u32()? as usize;
            Ok(String::from_utf8_lossy(self.take(n)?).into_owned())
        }
    }

    fn parse(err: &Located, opts: &ReadOptions, reply: &[u8]) -> Result<Volume, FieldError> {
        let mut c = Cursor(reply);
        let tag = c.u8().map_err(|m| err.bad(m))?;
        match tag {
            BAD => {
                let message = String::from_utf8_lossy(c.0).into_owned();
                // OpenVDB allocates as the file's node headers say: a corrupt count asks for
                // gigabytes, and the child's address space (3 x the grid cap + 2 GiB) ends it.
                if message.contains("bad_alloc") {
                    return Err(err.bad(format!(
                        "{message}: OpenVDB asked for more memory than the reader allows ({} MiB: \
                         3 x the grid cap + 2 GiB); the file is corrupt, or its tree is too \
                         large for the cap ({GRID_CAP_ENV})",
                        read_limit(opts.limits.max_bytes) >> 20
                    )));
                }
                return Err(err.bad(message));
            }
            OVER_CAP => {
                let mut dims = [0u64; 3];
                for d in &mut dims {
                    *d = c.u64().map_err(|m| err.bad(m))?;
                }
                err.limits_check(&opts.limits, dims)?;
                return Err(err.bad("the grid is over the memory cap"));
            }
            OK => {}
            _ => return Err(err.bad("the reader's reply is not one it writes")),
        }
        decode(err, opts, &mut c).map_err(|m| err.bad(m))?
    }

    fn decode(
        err: &Located,
        opts: &ReadOptions,
        c: &mut Cursor,
    ) -> Result<Result<Volume, FieldError>, String> {
        let name = c.str()?;
        let linear = c.u8()? != 0;
        let map_type = c.str()?;
        let mut rows = [[0f64; 4]; 4];
        for row in &mut rows {
            for v in row.iter_mut() {
                *v = c.f64()?;
            }
        }
        let min = [c.i32()?, c.i32()?, c.i32()?];
        let dims = [c.u64()?, c.u64()?, c.u64()?];
        let background = c.f64()?;
        let class = c.i32()?;
        let double = c.u8()? != 0;
        let half = c.u8()? != 0;
        let _active = c.u64()?;
        let _leaves = c.u64()?;
        let n = dims.iter().product::<u64>() as usize;
        let raw = c.take(n * 4)?;
        let values: Vec<f32> =
            raw.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        let class_name = match class {
            1 => "level set",
            2 => "fog volume",
            3 => "staggered",
            _ => "unknown class",
        };
        let dtype = format!(
            "{} {class_name} \"{}\" (background {}{})",
            if double { "double" } else { "float" },
            short(&name),
            super::super::num(background),
            if half { ", half floats on disk" } else { "" }
        );
        if !linear {
            if !opts.has_bounds {
                return Ok(Err(err.bad(format!(
                    "grid \"{}\": its transform ({}) is not a linear map isoview can place; \
                     set [field] bounds to place its index box",
                    short(&name),
                    short(&map_type)
                ))));
            }
            // `bounds` places the index box: the map's geometry is not used.
            let cols = [DVec3::X, DVec3::Y, DVec3::Z];
            return Ok(placed(err, dims, min, cols, DVec3::ZERO, values, dtype));
        }
        let col = |k: usize| DVec3::new(rows[k][0], rows[k][1], rows[k][2]);
        let t = DVec3::new(rows[3][0], rows[3][1], rows[3][2]);
        Ok(placed(err, dims, min, [col(0), col(1), col(2)], t, values, dtype))
    }
}
