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
//! The grid's box is the root's active-voxel index bounding box; it is sampled densely (under
//! the memory cap) leaf block by leaf block: a leaf's values (active or not) as stored, a
//! tile's value, or the background where the tree has nothing, as NanoVDB's getValue.

use std::collections::HashMap;
use std::io::Read;

use glam::DVec3;

use super::vdb::{box_dims, placed, select, short};
use super::{Located, ReadOptions, Volume};
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
    // The buffer holds the tree, which is at most about the dense box's size (it is checked
    // against the cap once the box is known); a buffer far over the cap is refused first.
    let most = opts.limits.max_bytes.saturating_mul(2).saturating_add(64 << 20);
    if g.grid_size > most {
        return Err(err.over_limit(format!(
            "grid {index}'s buffer is {} bytes, over the {} this reader takes at a memory cap of \
             {} MiB",
            g.grid_size,
            most,
            opts.limits.max_bytes >> 20
        )));
    }
    let buf = grid_bytes(err, &mut file, g)?;
    let tree = Tree::new(&buf).map_err(|m| err.bad(format!("grid \"{}\": {m}", short(&g.name))))?;
    let dims = box_dims(tree.bbox.0, tree.bbox.1, &g.name).map_err(|m| err.bad(m))?;
    err.limits_check(&opts.limits, dims)?;
    let values =
        tree.sample(dims).map_err(|m| err.bad(format!("grid \"{}\": {m}", short(&g.name))))?;
    let class = match tree.class {
        1 => "level set",
        2 => "fog volume",
        3 => "staggered",
        _ => "unknown class",
    };
    let dtype = format!(
        "NanoVDB float {class} \"{}\" (background {})",
        short(&g.name),
        super::num(f64::from(tree.background))
    );
    placed(err, dims, tree.bbox.0, tree.columns, tree.translation, values, dtype)
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

/// Where a voxel's value comes from.
enum Node {
    Leaf(usize),
    Value(f32),
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

    /// The leaf (or the constant) holding voxel `p`.
    fn find(&self, p: [i32; 3]) -> Result<Node, String> {
        let u = p.map(|c| c as u32);
        let key =
            u64::from(u[2] >> 12) | (u64::from(u[1] >> 12) << 21) | (u64::from(u[0] >> 12) << 42);
        let Some(&tile) = self.tiles.get(&key) else {
            return Ok(Node::Value(self.background));
        };
        let child = le_u64(self.buf, tile + 8) as i64;
        if child == 0 {
            return Ok(Node::Value(self.f32_at(tile + 20)));
        }
        let upper = self.child(self.root, child, UPPER_SIZE, "upper node")?;
        let n = (((u[0] & 4095) >> 7) << 10 | ((u[1] & 4095) >> 7) << 5 | ((u[2] & 4095) >> 7))
            as usize;
        let entry = upper + UPPER_TABLE + 8 * n;
        if !self.mask_on(upper + 32 + 4096, n) {
            return Ok(Node::Value(self.f32_at(entry)));
        }
        let lower = self.child(upper, le_u64(self.buf, entry) as i64, LOWER_SIZE, "lower node")?;
        let n =
            (((u[0] & 127) >> 3) << 8 | ((u[1] & 127) >> 3) << 4 | ((u[2] & 127) >> 3)) as usize;
        let entry = lower + LOWER_TABLE + 8 * n;
        if !self.mask_on(lower + 32 + 512, n) {
            return Ok(Node::Value(self.f32_at(entry)));
        }
        let leaf = self.child(lower, le_u64(self.buf, entry) as i64, LEAF_SIZE, "leaf")?;
        Ok(Node::Leaf(leaf))
    }

    /// The box's values, x fastest, one 8³ block's lookup at a time.
    fn sample(&self, dims: [u64; 3]) -> Result<Vec<f32>, String> {
        let (min, max) = (self.bbox.0.map(i64::from), self.bbox.1.map(i64::from));
        let d = dims.map(|v| v as usize);
        let mut out = vec![0f32; d[0] * d[1] * d[2]];
        let block = |c: i64| c & !7;
        let mut bz = block(min[2]);
        while bz <= max[2] {
            let mut by = block(min[1]);
            while by <= max[1] {
                let mut bx = block(min[0]);
                while bx <= max[0] {
                    let node = self.find([bx as i32, by as i32, bz as i32])?;
                    for z in bz.max(min[2])..=(bz + 7).min(max[2]) {
                        for y in by.max(min[1])..=(by + 7).min(max[1]) {
                            let row = ((z - min[2]) as usize * d[1] + (y - min[1]) as usize) * d[0];
                            for x in bx.max(min[0])..=(bx + 7).min(max[0]) {
                                out[row + (x - min[0]) as usize] = match node {
                                    Node::Value(v) => v,
                                    Node::Leaf(leaf) => {
                                        let n = ((x & 7) << 6 | (y & 7) << 3 | (z & 7)) as usize;
                                        self.f32_at(leaf + LEAF_VALUES + 4 * n)
                                    }
                                };
                            }
                        }
                    }
                    bx += 8;
                }
                by += 8;
            }
            bz += 8;
        }
        Ok(out)
    }
}
