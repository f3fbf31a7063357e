//! NanoVDB `.nvdb` files, read natively: NanoVDB is a flat, documented layout (NanoVDB.h and
//! util/IO.h of OpenVDB 10.0, NanoVDB 32.4, the version Debian's `vdb_tool` writes), so no
//! library is needed and the reader bounds-checks every offset it follows.
//!
//! A file is a sequence of segments: a 16-byte header (magic `NanoVDB0`, version, grid count,
//! codec), one 176-byte metadata record and the name for each grid, then each grid's buffer.
//! A buffer is the grid (672 bytes: map, class, type), the tree (node offsets), the root
//! (index box, background, a table of 32-byte tiles: key, child offset, state, value), upper
//! internal nodes of 32³ and lower ones of 16³ entries (masks, then an 8-byte table of values
//! or child offsets) and leaves of 8³ values. Float grids are read, uncompressed or ZIP (zlib);
//! BLOSC and the quantized types (Fp4, Fp8, Fp16, FpN, half) are refused with one line.
//!
//! The grid's box is the root's active-voxel index bounding box. The buffer is kept as it is
//! and becomes a sparse tree ([`crate::field::sparse::NodeTree`], every node checked to lie
//! in the buffer once, when the tree is walked here): a voxel is a leaf's value (active or
//! not) as stored, a tile's value, or the background where the tree has nothing, as
//! NanoVDB's getValue.

use std::collections::HashMap;
use std::io::Read;
use std::sync::Arc;

use glam::DVec3;

use super::vdb::{box_dims, placed, select, short};
use super::{Located, ReadOptions, Volume};
use crate::field::sparse::{NodeTree, SparseTree};
use crate::field::FieldError;

const MAGIC: u64 = 0x3042_4456_6f6e_614e; // "NanoVDB0"
const HEADER: u64 = 16;
const META: u64 = 176;
const GRID_DATA: usize = 672;
const TREE_DATA: usize = 64;
/// GridType::Float; the others are named in the refusal.
const FLOAT: u32 = 1;
const TYPES: [&str; 19] = [
    "unknown", "float", "double", "int16", "int32", "int64", "vec3f", "vec3d", "mask", "half",
    "uint32", "bool", "rgba8", "fp4", "fp8", "fp16", "fpn", "vec4f", "vec4d",
];
/// Bytes a node costs in the sparse tree's tables (a hash-map entry and its share of the
/// table's slack) besides the buffer, counted against the cap.
const NODE_BYTES: u64 = 64;

/// The longest grid name a metadata record may declare.
const MAX_NAME: u32 = 1 << 16;

/// Node layouts of a float tree (offsets in bytes; NanoVDB aligns each node to 32 bytes).
const ROOT_SIZE: usize = 64;
const ROOT_TILE: usize = 32;
const UPPER_TABLE: usize = 8256;
const UPPER_SIZE: usize = UPPER_TABLE + 8 * 32768;
const LOWER_TABLE: usize = 1088;
const LOWER_SIZE: usize = LOWER_TABLE + 8 * 4096;
const LEAF_VALUES: usize = 96;
const LEAF_SIZE: usize = LEAF_VALUES + 4 * 512;

fn type_name(t: u32) -> &'static str {
    TYPES.get(t as usize).copied().unwrap_or("unknown")
}

struct GridMeta {
    name: String,
    grid_type: u32,
    grid_size: u64,
    file_size: u64,
    /// Where the grid's bytes start in the file.
    offset: u64,
    codec: u16,
}

pub(super) fn read(err: &Located, opts: &ReadOptions) -> Result<Volume, FieldError> {
    let mut file = err.access.open(err.path).map_err(|e| err.io(&e))?;
    let len = file.metadata().map_err(|e| err.io(&e))?.len();
    let grids = segments(err, &mut file, len)?;
    let listed: Vec<(String, String)> =
        grids.iter().map(|g| (g.name.clone(), type_name(g.grid_type).to_string())).collect();
    let index = select(&listed, opts.grid.as_deref(), &|t| t == "float", "float")
        .map_err(|m| err.bad(m))?;
    let g = &grids[index];
    // The buffer is the tree, and it is what is held (sparse, never densified here): it is
    // checked against the cap before it is read.
    let cap = opts.limits.max_bytes;
    if g.grid_size > cap {
        let mib = g.grid_size.div_ceil(1 << 20);
        return Err(err.over_limit(format!(
            "grid {index}'s buffer (its tree) is {mib} MiB, over the cap of {} MiB; raise the \
             cap with {}={mib}",
            cap >> 20,
            crate::field::GRID_CAP_ENV
        )));
    }
    let buf = grid_bytes(err, &mut file, g)?;
    let named = |m: String| err.bad(format!("grid \"{}\": {m}", short(&g.name)));
    let tree = Tree::new(&buf).map_err(named)?;
    let dims = box_dims(tree.bbox.0, tree.bbox.1, &g.name).map_err(|m| err.bad(m))?;
    let nodes = tree.nodes().map_err(named)?;
    // The node tables come on top of the buffer (a tile-filled buffer holds millions of
    // nodes): both under the cap, before the tables are built.
    let held = buf.len() as u64 + nodes.len() as u64 * NODE_BYTES;
    if held > cap {
        let mib = held.div_ceil(1 << 20);
        return Err(err.over_limit(format!(
            "grid {index}'s tree ({} nodes in a buffer of {} MiB) takes {mib} MiB, over the cap \
             of {} MiB; raise the cap with {}={mib}",
            nodes.len(),
            buf.len() >> 20,
            cap >> 20,
            crate::field::GRID_CAP_ENV
        )));
    }
    let (background, class, columns, translation, min) =
        (tree.background, tree.class, tree.columns, tree.translation, tree.bbox.0);
    let mut sparse = NodeTree::new(buf, background, 8);
    for (kind, origin, at, value) in nodes {
        match kind {
            Kind::RootTile => sparse.add_root_tile(origin, value),
            Kind::Upper => sparse.add_upper(origin, at),
            Kind::Lower => sparse.add_lower(origin, at),
            Kind::Leaf => sparse.add_leaf(origin, at),
        }
        .map_err(named)?;
    }
    let tree =
        SparseTree { tree: Arc::new(sparse), index_min: min, dims: dims.map(|d| d as usize) };
    let class = match class {
        1 => "level set",
        2 => "fog volume",
        3 => "staggered",
        _ => "unknown class",
    };
    let dtype = format!(
        "NanoVDB float {class} \"{}\" (background {})",
        short(&g.name),
        super::num(f64::from(background))
    );
    placed(err, dims, min, columns, translation, Vec::new(), dtype)
        .map(|v| Volume { sparse: Some(tree), ..v })
}

/// A node [`Tree::nodes`] found: its kind, origin, where its entries or values start, and a
/// root tile's value.
type Found = (Kind, [i32; 3], usize, f32);

/// A node of the tree, as [`Tree::nodes`] finds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    RootTile,
    Upper,
    Lower,
    Leaf,
}

/// Every grid's metadata, segment by segment, up to the end of the file.
fn segments(
    err: &Located,
    file: &mut std::fs::File,
    len: u64,
) -> Result<Vec<GridMeta>, FieldError> {
    let mut grids = Vec::new();
    let mut at = 0u64;
    while at < len {
        let h = read_at(err, file, at, HEADER, len)?;
        if le_u64(&h, 0) != MAGIC {
            return Err(err.bad(format!("byte {at}: no NanoVDB segment header (magic NanoVDB0)")));
        }
        let version = le_u32(&h, 8);
        let (major, minor, patch) = (version >> 21, (version >> 10) & 0x7ff, version & 0x3ff);
        if major != 32 || minor != 4 {
            return Err(err.bad(format!(
                "NanoVDB version {major}.{minor}.{patch}; isoview reads 32.4 (OpenVDB 10's, \
                 Debian's vdb_tool)"
            )));
        }
        let count = u64::from(le_u16(&h, 12));
        let codec = le_u16(&h, 14);
        if grids.len() as u64 + count > super::vdb::MAX_GRIDS as u64 {
            return Err(
                err.bad(format!("more than {} grids, isoview's limit", super::vdb::MAX_GRIDS))
            );
        }
        at += HEADER;
        let first = grids.len();
        for _ in 0..count {
            let m = read_at(err, file, at, META, len)?;
            let name_size = le_u32(&m, 136);
            if name_size > MAX_NAME {
                return Err(err.bad(format!("byte {at}: a grid name of {name_size} bytes")));
            }
            let name = read_at(err, file, at + META, u64::from(name_size), len)?;
            let name = name.split(|&b| b == 0).next().unwrap_or(&[]);
            grids.push(GridMeta {
                name: String::from_utf8_lossy(name).into_owned(),
                grid_type: le_u32(&m, 32),
                grid_size: le_u64(&m, 0),
                file_size: le_u64(&m, 8),
                offset: 0,
                codec,
            });
            at += META + u64::from(name_size);
        }
        for g in &mut grids[first..] {
            g.offset = at;
            at = at.checked_add(g.file_size).filter(|&e| e <= len).ok_or_else(|| {
                err.bad(format!(
                    "grid \"{}\" declares {} bytes at byte {at}, past the end of the file ({len} \
                     bytes)",
                    short(&g.name),
                    g.file_size
                ))
            })?;
        }
    }
    if grids.is_empty() {
        return Err(err.bad("no NanoVDB segment (the file is empty)"));
    }
    Ok(grids)
}

/// `n` bytes at `at`, or the line saying the file ends first.
fn read_at(
    err: &Located,
    file: &std::fs::File,
    at: u64,
    n: u64,
    len: u64,
) -> Result<Vec<u8>, FieldError> {
    use std::os::unix::fs::FileExt;
    if at.checked_add(n).map_or(true, |e| e > len) {
        return Err(err
            .bad(format!("the file ends at byte {len}, inside the {n}-byte record at byte {at}")));
    }
    let mut b = vec![0u8; n as usize];
    file.read_exact_at(&mut b, at).map_err(|e| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => FieldError::Io {
            path: err.path.to_path_buf(),
            message: format!("shrank to under {} bytes while being read", at + n),
        },
        _ => err.io(&e),
    })?;
    Ok(b)
}

/// The grid's buffer, decompressed.
fn grid_bytes(
    err: &Located,
    file: &mut std::fs::File,
    g: &GridMeta,
) -> Result<Vec<u8>, FieldError> {
    let len = g.offset + g.file_size;
    match g.codec {
        0 => {
            if g.file_size != g.grid_size {
                return Err(err.bad(format!(
                    "grid \"{}\": {} bytes in the file for a {}-byte grid (no codec)",
                    short(&g.name),
                    g.file_size,
                    g.grid_size
                )));
            }
            read_at(err, file, g.offset, g.grid_size, len)
        }
        1 => {
            let size = read_at(err, file, g.offset, 8, len)?;
            let size = le_u64(&size, 0);
            if size.checked_add(8) != Some(g.file_size) {
                return Err(err.bad(format!(
                    "grid \"{}\": a ZIP block of {size} bytes in {} bytes",
                    short(&g.name),
                    g.file_size
                )));
            }
            let zipped = read_at(err, file, g.offset + 8, size, len)?;
            let mut out = Vec::new();
            let mut z = flate2::read::ZlibDecoder::new(&zipped[..]).take(g.grid_size + 1);
            z.read_to_end(&mut out)
                .map_err(|e| err.bad(format!("grid \"{}\": ZIP data: {e}", short(&g.name))))?;
            if out.len() as u64 != g.grid_size {
                return Err(err.bad(format!(
                    "grid \"{}\": ZIP data holds {}{} bytes for a {}-byte grid",
                    short(&g.name),
                    if out.len() as u64 > g.grid_size { "over " } else { "" },
                    out.len().min(g.grid_size as usize),
                    g.grid_size
                )));
            }
            Ok(out)
        }
        2 => Err(err.bad(
            "BLOSC-compressed NanoVDB; isoview reads uncompressed and ZIP ones (vdb_tool -write \
             codec=zip or codec=none)",
        )),
        c => Err(err.bad(format!("unknown NanoVDB codec {c}"))),
    }
}

fn le_u16(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}
fn le_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap_or_default())
}
fn le_u64(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap_or_default())
}

/// A float grid's buffer, checked node by node as it is walked.
struct Tree<'a> {
    buf: &'a [u8],
    root: usize,
    /// Root tiles by key (a tile's offset in the buffer).
    tiles: HashMap<u64, usize>,
    bbox: ([i32; 3], [i32; 3]),
    background: f32,
    class: u32,
    columns: [DVec3; 3],
    translation: DVec3,
}

impl<'a> Tree<'a> {
    fn new(buf: &'a [u8]) -> Result<Tree<'a>, String> {
        if buf.len() < GRID_DATA + TREE_DATA {
            return Err(format!("a buffer of {} bytes holds no grid", buf.len()));
        }
        if le_u64(buf, 0) != MAGIC {
            return Err("the grid's magic is not NanoVDB0".into());
        }
        let grid_type = le_u32(buf, 636);
        if grid_type != FLOAT {
            return Err(format!(
                "a {} grid; isoview reads float NanoVDB grids",
                type_name(grid_type)
            ));
        }
        let class = le_u32(buf, 632);
        let f64_at = |at: usize| f64::from_le_bytes(buf[at..at + 8].try_into().unwrap_or_default());
        // Map: float matrix, inverse, vector, taper (88 bytes), then the doubles.
        let mat = 296 + 88;
        let m: Vec<f64> = (0..9).map(|i| f64_at(mat + 8 * i)).collect();
        let vec = mat + 2 * 72;
        let translation = DVec3::new(f64_at(vec), f64_at(vec + 8), f64_at(vec + 16));
        let columns = [0, 1, 2].map(|k| DVec3::new(m[k], m[3 + k], m[6 + k]));
        let root_offset = le_u64(buf, GRID_DATA + 24);
        let root = usize::try_from(root_offset)
            .ok()
            .and_then(|o| o.checked_add(GRID_DATA))
            .filter(|&r| r.checked_add(ROOT_SIZE).is_some_and(|e| e <= buf.len()))
            .ok_or_else(|| format!("the root's offset {root_offset} is outside the buffer"))?;
        let i32_at = |at: usize| le_u32(buf, at) as i32;
        let bbox = (
            [i32_at(root), i32_at(root + 4), i32_at(root + 8)],
            [i32_at(root + 12), i32_at(root + 16), i32_at(root + 20)],
        );
        let table = le_u32(buf, root + 24) as usize;
        let background =
            f32::from_le_bytes(buf[root + 28..root + 32].try_into().unwrap_or_default());
        let first = root + ROOT_SIZE;
        if table
            .checked_mul(ROOT_TILE)
            .and_then(|t| t.checked_add(first))
            .map_or(true, |e| e > buf.len())
        {
            return Err(format!("the root's {table} tiles run past the buffer"));
        }
        let mut tiles = HashMap::with_capacity(table);
        for t in 0..table {
            let at = first + t * ROOT_TILE;
            tiles.insert(le_u64(buf, at), at);
        }
        Ok(Tree { buf, root, tiles, bbox, background, class, columns, translation })
    }

    fn f32_at(&self, at: usize) -> f32 {
        f32::from_le_bytes(self.buf[at..at + 4].try_into().unwrap_or_default())
    }

    /// The node `offset` bytes from `base`, checked to lie in the buffer with `size` bytes.
    fn child(&self, base: usize, offset: i64, size: usize, what: &str) -> Result<usize, String> {
        let at = (base as i64).checked_add(offset).and_then(|a| usize::try_from(a).ok());
        at.filter(|&a| a.checked_add(size).is_some_and(|e| e <= self.buf.len())).ok_or_else(|| {
            format!("a {what} at offset {offset} from byte {base} is outside the buffer")
        })
    }

    fn mask_on(&self, mask: usize, n: usize) -> bool {
        self.buf[mask + (n >> 3)] & (1 << (n & 7)) != 0
    }

    /// Every node under the root, checked to lie in the buffer: root tiles with their value,
    /// internal nodes with where their entries start, leaves with where their values start;
    /// origins from the walk (a root tile's key, then each child's entry). A buffer that names
    /// more nodes than it can hold (children shared by several entries) is refused: the walk
    /// is bounded by the buffer's size.
    fn nodes(&self) -> Result<Vec<Found>, String> {
        let most = |size: usize| self.buf.len() / size;
        let (mut uppers, mut lowers, mut leaves) = (0usize, 0usize, 0usize);
        let too_many = |what: &str| format!("the tree names more {what} than its buffer holds");
        let mut out = Vec::new();
        let mut tiles: Vec<(u64, usize)> = self.tiles.iter().map(|(&k, &a)| (k, a)).collect();
        tiles.sort_unstable();
        for (key, tile) in tiles {
            let axis = |shift: u32| ((((key >> shift) & 0x1F_FFFF) as u32) << 12) as i32;
            let origin = [axis(42), axis(21), axis(0)];
            let child = le_u64(self.buf, tile + 8) as i64;
            if child == 0 {
                out.push((Kind::RootTile, origin, 0, self.f32_at(tile + 20)));
                continue;
            }
            // Tiles sharing one upper node would walk it once each: bounded like the others.
            uppers += 1;
            if uppers > most(UPPER_SIZE) {
                return Err(too_many("upper nodes"));
            }
            let upper = self.child(self.root, child, UPPER_SIZE, "upper node")?;
            out.push((Kind::Upper, origin, upper + UPPER_TABLE, 0.0));
            for n in (0..32768).filter(|&n| self.mask_on(upper + 32 + 4096, n)) {
                lowers += 1;
                if lowers > most(LOWER_SIZE) {
                    return Err(too_many("lower nodes"));
                }
                let entry = upper + UPPER_TABLE + 8 * n;
                let lower =
                    self.child(upper, le_u64(self.buf, entry) as i64, LOWER_SIZE, "lower node")?;
                let at = |n: usize, shift: usize, side: i32| {
                    ((n >> shift) & if side == 128 { 31 } else { 15 }) as i32 * side
                };
                let lo = [0, 1, 2].map(|k| origin[k] + at(n, 10 - 5 * k, 128));
                out.push((Kind::Lower, lo, lower + LOWER_TABLE, 0.0));
                for m in (0..4096).filter(|&m| self.mask_on(lower + 32 + 512, m)) {
                    leaves += 1;
                    if leaves > most(LEAF_SIZE) {
                        return Err(too_many("leaves"));
                    }
                    let entry = lower + LOWER_TABLE + 8 * m;
                    let leaf =
                        self.child(lower, le_u64(self.buf, entry) as i64, LEAF_SIZE, "leaf")?;
                    let o = [0, 1, 2].map(|k| lo[k] + at(m, 8 - 4 * k, 8));
                    out.push((Kind::Leaf, o, leaf + LEAF_VALUES, 0.0));
                }
            }
        }
        Ok(out)
    }
}
