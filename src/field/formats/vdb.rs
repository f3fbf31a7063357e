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
    let dims = [0, 1, 2].map(|k| (i64::from(max[k]) - i64::from(min[k]) + 1) as u64);
    // Every count derived from the box (its f32 bytes, its bricks) must fit a u64.
    if dims.iter().try_fold(4u64, |a, &d| a.checked_mul(d)).is_none() {
        return Err(format!(
            "grid \"{}\": its active-voxel box of {}x{}x{} voxels is beyond what isoview \
             addresses",
            short(name),
            dims[0],
            dims[1],
            dims[2]
        ));
    }
    Ok(dims)
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
        sparse: None,
    };
    v.set_axes(columns, "the grid's transform", err)?;
    Ok(v)
}

#[cfg(feature = "openvdb")]
pub(super) use with_library::read;

#[cfg(feature = "openvdb")]
mod with_library {
    use std::time::Duration;

    use std::sync::Arc;

    use glam::DVec3;
    use isoview_openvdb as ovdb;

    use super::{box_dims, placed, select, short, Located, ReadOptions, Volume};
    use crate::field::sparse::{NodeTree, SparseTree};
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
        // In this process first: the child then finds OpenVDB set up and registers no exit
        // handler (a fork while another thread held the atexit lock hung the child).
        ovdb::initialize();
        let reply = ovdb::isolated(limits, move || child(&path, wanted.as_deref(), cap))
            .map_err(|e| err.bad(e.to_string()))?;
        parse(err, opts, reply.into_buffer())
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
        // The tree is what is held (sparse, never densified here): its export is checked
        // against the cap before it is written.
        let counts = match grid.tree_counts() {
            Ok(c) => c,
            Err(e) => return bad(format!("grid \"{}\": {e}", short(&name))),
        };
        let bytes = counts.export_bytes().unwrap_or(u64::MAX);
        if bytes > cap {
            let mut r = vec![OVER_CAP];
            for v in [bytes, counts.leaves, counts.lower, counts.upper] {
                r.extend_from_slice(&v.to_le_bytes());
            }
            return Ok(r);
        }
        let mut r = Vec::with_capacity(bytes as usize + 1024);
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
        for v in [counts.root_tiles, counts.upper, counts.lower, counts.leaves] {
            r.extend_from_slice(&v.to_le_bytes());
        }
        // The nodes straight into the reply: the child holds OpenVDB's tree and one export.
        let at = r.len();
        r.resize(at + bytes as usize, 0);
        if let Err(e) = grid.export(&counts, &mut r[at..]) {
            return bad(format!("grid \"{}\": {e}", short(&name)));
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

    fn parse(err: &Located, opts: &ReadOptions, reply: Vec<u8>) -> Result<Volume, FieldError> {
        // Byte 0 is isolate's tag; the child's own reply follows.
        let mut c = Cursor(&reply[1.min(reply.len())..]);
        let tag = c.u8().map_err(|m| err.bad(m))?;
        match tag {
            BAD => {
                let message = String::from_utf8_lossy(c.0).into_owned();
                // OpenVDB allocates as the file's node headers say: a corrupt count asks for
                // gigabytes, and the child's address space (3 x the grid cap + 2 GiB: a tree
                // under the cap, its export and the library) ends it.
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
                let mut v = [0u64; 4];
                for x in &mut v {
                    *x = c.u64().map_err(|m| err.bad(m))?;
                }
                let [bytes, leaves, lower, upper] = v;
                let mib = |b: u64| b.div_ceil(1 << 20);
                return Err(err.over_limit(format!(
                    "the grid's tree ({leaves} leaves, {lower} lower and {upper} upper internal \
                     nodes) takes {} MiB, over the cap of {} MiB; raise the cap with \
                     {GRID_CAP_ENV}={}",
                    mib(bytes),
                    opts.limits.max_bytes >> 20,
                    mib(bytes)
                )));
            }
            OK => {}
            _ => return Err(err.bad("the reader's reply is not one it writes")),
        }
        let header = decode(&mut c).map_err(|m| err.bad(m))?;
        let start = reply.len() - c.0.len();
        let tree = nodes(reply, start, &header).map_err(|m| err.bad(m))?;
        volume(err, opts, header, tree)
    }

    /// What the reply says of the grid, before its nodes.
    struct Header {
        name: String,
        linear: bool,
        map_type: String,
        rows: [[f64; 4]; 4],
        min: [i32; 3],
        dims: [u64; 3],
        background: f64,
        class: i32,
        double: bool,
        half: bool,
        counts: [u64; 4],
    }

    fn decode(c: &mut Cursor) -> Result<Header, String> {
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
        let counts = [c.u64()?, c.u64()?, c.u64()?, c.u64()?];
        Ok(Header {
            name,
            linear,
            map_type,
            rows,
            min,
            dims,
            background,
            class,
            double,
            half,
            counts,
        })
    }

    /// The tree over the reply's records from byte `start` (`isoview_openvdb::Grid::export`'s
    /// layout), the buffer kept as the nodes' storage.
    fn nodes(reply: Vec<u8>, start: usize, h: &Header) -> Result<NodeTree, String> {
        let [tiles, upper, lower, leaves] = h.counts;
        let records = [
            (tiles, ovdb::ROOT_TILE_RECORD),
            (upper, ovdb::UPPER_RECORD),
            (lower, ovdb::LOWER_RECORD),
            (leaves, ovdb::LEAF_RECORD),
        ];
        let total =
            records.iter().map(|&(n, b)| n.saturating_mul(b)).fold(0u64, u64::saturating_add);
        if (reply.len() - start) as u64 != total {
            return Err("the reader's reply is cut short".into());
        }
        let mut tree = NodeTree::new(reply, h.background as f32, 4);
        let i32_at =
            |b: &[u8], at: usize| i32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
        let mut at = start;
        for (kind, &(n, size)) in records.iter().enumerate() {
            for _ in 0..n {
                let b = tree.buffer();
                let origin = [i32_at(b, at), i32_at(b, at + 4), i32_at(b, at + 8)];
                match kind {
                    0 => {
                        let v =
                            f32::from_le_bytes([b[at + 12], b[at + 13], b[at + 14], b[at + 15]]);
                        tree.add_root_tile(origin, v)?
                    }
                    1 => tree.add_upper(origin, at + 12)?,
                    2 => tree.add_lower(origin, at + 12)?,
                    _ => tree.add_leaf(origin, at + 12)?,
                }
                at += size as usize;
            }
        }
        Ok(tree)
    }

    fn volume(
        err: &Located,
        opts: &ReadOptions,
        h: Header,
        tree: NodeTree,
    ) -> Result<Volume, FieldError> {
        let Header {
            name, linear, map_type, rows, min, dims, background, class, double, half, ..
        } = h;
        let d = dims.map(|v| v as usize);
        let sparse = SparseTree { tree: Arc::new(tree), index_min: min, dims: d };
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
                return Err(err.bad(format!(
                    "grid \"{}\": its transform ({}) is not a linear map isoview can place; \
                     set [field] bounds to place its index box",
                    short(&name),
                    short(&map_type)
                )));
            }
            // `bounds` places the index box: the map's geometry is not used.
            let cols = [DVec3::X, DVec3::Y, DVec3::Z];
            return placed(err, dims, min, cols, DVec3::ZERO, Vec::new(), dtype)
                .map(|v| Volume { sparse: Some(sparse), ..v });
        }
        let col = |k: usize| DVec3::new(rows[k][0], rows[k][1], rows[k][2]);
        let t = DVec3::new(rows[3][0], rows[3][1], rows[3][2]);
        placed(err, dims, min, [col(0), col(1), col(2)], t, Vec::new(), dtype)
            .map(|v| Volume { sparse: Some(sparse), ..v })
    }
}
