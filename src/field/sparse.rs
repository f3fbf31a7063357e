//! Sparse grids: OpenVDB (`.vdb`) and NanoVDB (`.nvdb`) trees held as they are, never
//! densified by the paths that read a grid in parts (docs/formats.md "Sparse").
//!
//! Both formats are OpenVDB's 5-4-3 tree: a root table of tiles and upper internal nodes of
//! 32³ entries (4096³ voxels), lower internal nodes of 16³ entries (128³ voxels), leaves of 8³
//! voxels. [`NodeTree`] holds one such tree over one buffer (the OpenVDB reader's reply, or the
//! NanoVDB grid's own bytes) with the nodes found by origin: the only lookup a reader needs is
//! [`NodeTree::block`], the 8³ leaf-aligned block holding a voxel — a leaf's values, or one
//! value (a tile's, or the background) for every voxel of the block. That is OpenVDB's
//! `getValue`: a voxel in a leaf has the leaf's value (active or not), else the tile of the
//! internal node holding it, else the root's tile, else the background.
//!
//! [`SparseTree`] places the tree's active-voxel box on isoview's grid points (index
//! coordinates `index_min + p`) and reads boxes of it ([`SparseTree::read_box`]) and the
//! brick ranges of the brick pool ([`SparseTree::brick_ranges`]) a leaf block at a time; a
//! block that is one value costs one lookup whatever its size.

use std::ops::Range;
use std::sync::Arc;

use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;

use super::interpolant::{widen, STENCIL};
use super::{FieldError, NanPolicy};

/// Voxels per side of a leaf (and of the blocks reads go by).
pub const LEAF: i64 = 8;
/// Voxels per side of a lower internal node.
const LOWER: i32 = 128;
/// Voxels per side of an upper internal node (and of a root tile).
const UPPER: i32 = 4096;

/// An 8³ block of voxels: a leaf's values or one value for all.
#[derive(Clone, Copy, Debug)]
pub enum Block<'a> {
    /// Every voxel of the block has this value (a tile's, or the background).
    Value(f32),
    /// A leaf's 512 values, little-endian f32, in OpenVDB's order: voxel (x, y, z) of the
    /// leaf at `4 * (x << 6 | y << 3 | z)`.
    Leaf(&'a [u8]),
}

impl Block<'_> {
    /// The value of voxel `p` (index coordinates) of the block.
    #[inline]
    pub fn at(&self, p: [i64; 3]) -> f32 {
        match *self {
            Block::Value(v) => v,
            Block::Leaf(b) => {
                let n = (((p[0] & 7) << 6) | ((p[1] & 7) << 3) | (p[2] & 7)) as usize * 4;
                f32::from_le_bytes([b[n], b[n + 1], b[n + 2], b[n + 3]])
            }
        }
    }
}

/// A 5-4-3 tree over one buffer, its nodes found by origin.
pub struct NodeTree {
    buf: Vec<u8>,
    background: f32,
    /// Bytes from one internal-node entry to the next (4 in the OpenVDB reader's records,
    /// 8 in NanoVDB, whose entries are a value or a child offset).
    stride: usize,
    root_tiles: HashMap<[i32; 3], f32>,
    /// Upper and lower internal nodes: where entry 0 is in the buffer.
    uppers: HashMap<[i32; 3], usize>,
    lowers: HashMap<[i32; 3], usize>,
    /// Leaves: where value 0 is.
    leaves: HashMap<[i32; 3], usize>,
}

impl NodeTree {
    /// An empty tree (every voxel the background) over `buf`, internal entries `stride` bytes
    /// apart.
    pub fn new(buf: Vec<u8>, background: f32, stride: usize) -> NodeTree {
        NodeTree {
            buf,
            background,
            stride,
            root_tiles: HashMap::default(),
            uppers: HashMap::default(),
            lowers: HashMap::default(),
            leaves: HashMap::default(),
        }
    }

    /// The buffer, for readers that decode records from it.
    pub fn buffer(&self) -> &[u8] {
        &self.buf
    }

    fn room(&self, at: usize, bytes: usize, what: &str) -> Result<(), String> {
        match at.checked_add(bytes) {
            Some(end) if end <= self.buf.len() => Ok(()),
            _ => Err(format!("a {what} at byte {at} runs past the buffer")),
        }
    }

    fn aligned(origin: [i32; 3], side: i32, what: &str) -> Result<(), String> {
        match origin.iter().all(|&c| c.rem_euclid(side) == 0) {
            true => Ok(()),
            false => Err(format!("a {what} at {origin:?} is not on its {side}-voxel lattice")),
        }
    }

    pub fn add_root_tile(&mut self, origin: [i32; 3], value: f32) -> Result<(), String> {
        Self::aligned(origin, UPPER, "root tile")?;
        self.root_tiles.insert(origin, value);
        Ok(())
    }

    /// An upper internal node whose 32³ entries start at byte `at`.
    pub fn add_upper(&mut self, origin: [i32; 3], at: usize) -> Result<(), String> {
        Self::aligned(origin, UPPER, "upper node")?;
        self.room(at, 32768 * self.stride, "upper node")?;
        self.uppers.insert(origin, at);
        Ok(())
    }

    /// A lower internal node whose 16³ entries start at byte `at`.
    pub fn add_lower(&mut self, origin: [i32; 3], at: usize) -> Result<(), String> {
        Self::aligned(origin, LOWER, "lower node")?;
        self.room(at, 4096 * self.stride, "lower node")?;
        self.lowers.insert(origin, at);
        Ok(())
    }

    /// A leaf whose 512 values start at byte `at`.
    pub fn add_leaf(&mut self, origin: [i32; 3], at: usize) -> Result<(), String> {
        Self::aligned(origin, LEAF as i32, "leaf")?;
        self.room(at, 2048, "leaf")?;
        self.leaves.insert(origin, at);
        Ok(())
    }

    /// Whether a lower internal node has its origin at `o` (a region of 128³ voxels with no
    /// lower node is one value: an upper node's tile, a root tile or the background).
    pub fn has_lower(&self, o: [i32; 3]) -> bool {
        self.lowers.contains_key(&o)
    }

    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    /// Bytes held: the buffer and the node tables.
    pub fn bytes(&self) -> u64 {
        let entry = std::mem::size_of::<([i32; 3], usize)>() as u64 * 2;
        let nodes = self.uppers.len() + self.lowers.len() + self.leaves.len();
        self.buf.capacity() as u64 + (nodes + self.root_tiles.len()) as u64 * entry
    }

    fn entry(&self, at: usize, n: usize) -> f32 {
        let i = at + n * self.stride;
        let b = &self.buf[i..i + 4];
        f32::from_le_bytes([b[0], b[1], b[2], b[3]])
    }

    /// The block of 8³ voxels whose origin (each coordinate a multiple of 8) is `o`.
    pub fn block(&self, o: [i32; 3]) -> Block<'_> {
        if let Some(&at) = self.leaves.get(&o) {
            return Block::Leaf(&self.buf[at..at + 2048]);
        }
        // Entry offsets as OpenVDB's coordToOffset: x slowest, z fastest.
        let lower = o.map(|c| c & !(LOWER - 1));
        if let Some(&at) = self.lowers.get(&lower) {
            let [x, y, z] = o.map(|c| ((c & (LOWER - 1)) >> 3) as usize);
            return Block::Value(self.entry(at, (x << 8) | (y << 4) | z));
        }
        let upper = o.map(|c| c & !(UPPER - 1));
        if let Some(&at) = self.uppers.get(&upper) {
            let [x, y, z] = o.map(|c| ((c & (UPPER - 1)) >> 7) as usize);
            return Block::Value(self.entry(at, (x << 10) | (y << 5) | z));
        }
        Block::Value(self.root_tiles.get(&upper).copied().unwrap_or(self.background))
    }
}

/// A tree placed on isoview's grid points: point `p` is voxel `index_min + p`.
#[derive(Clone)]
pub struct SparseTree {
    pub tree: Arc<NodeTree>,
    /// Index coordinates of grid point (0, 0, 0): the active-voxel box's first corner.
    pub index_min: [i32; 3],
    /// Points along x, y, z (the active-voxel box).
    pub dims: [usize; 3],
}

impl PartialEq for SparseTree {
    fn eq(&self, other: &SparseTree) -> bool {
        Arc::ptr_eq(&self.tree, &other.tree)
            && (self.index_min, self.dims) == (other.index_min, other.dims)
    }
}

impl std::fmt::Debug for SparseTree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseTree")
            .field("index_min", &self.index_min)
            .field("dims", &self.dims)
            .field("leaves", &self.tree.leaf_count())
            .finish()
    }
}

fn out_len(n: [usize; 3]) -> usize {
    n[0] * n[1] * n[2]
}

/// The blocks (their first voxel's index coordinate) a run of voxels `a ..= b` meets.
fn blocks(a: i64, b: i64) -> impl Iterator<Item = i64> {
    let first = a.div_euclid(LEAF) * LEAF;
    (first..=b).step_by(LEAF as usize)
}

impl SparseTree {
    /// The index coordinate of grid point `p` along axis `a`.
    fn index(&self, a: usize, p: usize) -> i64 {
        i64::from(self.index_min[a]) + p as i64
    }

    /// The block holding index coordinate `o` (any voxel of it).
    fn block_at(&self, o: [i64; 3]) -> Block<'_> {
        // Index coordinates of a box whose corners are i32 stay in i32.
        self.tree.block(o.map(|c| (c.div_euclid(LEAF) * LEAF) as i32))
    }

    /// Every point of the box, x fastest (a dense copy: for the paths that need the grid
    /// whole, under the memory cap).
    pub fn dense(&self) -> Vec<f32> {
        self.read_box([0, 0, 0], self.dims)
    }

    /// The points `lo .. lo + n` (inside the box), x fastest; one lookup per 8³ block, the
    /// block layers along z in parallel.
    pub fn read_box(&self, lo: [usize; 3], n: [usize; 3]) -> Vec<f32> {
        let mut out = vec![0f32; n[0] * n[1] * n[2]];
        if out.is_empty() {
            return out;
        }
        let plane = n[0] * n[1];
        let (z0, z1) = (self.index(2, lo[2]), self.index(2, lo[2] + n[2] - 1));
        // The output split at block boundaries along z: one piece per block layer.
        let mut pieces = Vec::new();
        let mut rest = out.as_mut_slice();
        for bz in blocks(z0, z1) {
            let (a, b) = (bz.max(z0), (bz + LEAF - 1).min(z1));
            let (piece, tail) = rest.split_at_mut(plane * (b - a + 1) as usize);
            pieces.push((a, b, piece));
            rest = tail;
        }
        let (x0, y0) = (self.index(0, lo[0]), self.index(1, lo[1]));
        let (x1, y1) = (x0 + n[0] as i64 - 1, y0 + n[1] as i64 - 1);
        let fill = |(za, zb, piece): (i64, i64, &mut [f32])| {
            for by in blocks(y0, y1) {
                for bx in blocks(x0, x1) {
                    let block = self.block_at([bx, by, za]);
                    let xs = bx.max(x0)..=(bx + LEAF - 1).min(x1);
                    for z in za..=zb {
                        for y in by.max(y0)..=(by + LEAF - 1).min(y1) {
                            let row = ((z - za) as usize * n[1] + (y - y0) as usize) * n[0];
                            let at = |x: i64| row + (x - x0) as usize;
                            match block {
                                Block::Value(v) => {
                                    piece[at(*xs.start())..=at(*xs.end())].fill(v);
                                }
                                Block::Leaf(_) => {
                                    for x in xs.clone() {
                                        piece[at(x)] = block.at([x, y, z]);
                                    }
                                }
                            }
                        }
                    }
                }
            }
        };
        // A brick pool's slot (11³ points) is read on a thread of the upload's own parallel
        // loop: small boxes are filled in place, larger ones a block layer a thread.
        if out_len(n) < 1 << 16 {
            pieces.into_iter().for_each(fill);
        } else {
            pieces.into_par_iter().for_each(fill);
        }
        out
    }

    /// The min/max of every brick of `brick` cells over the points it reads, as
    /// [`super::mapped::MappedGrid::brick_ranges`] lays them out (the same values for the
    /// same samples); with `field.nan = "error"` fails on the first non-finite sample met
    /// (`what` names the grid), with `"empty"` leaves it out of the range. A block that is one
    /// value widens a brick once; the brick layers along z run in parallel.
    pub fn brick_ranges(
        &self,
        brick: usize,
        nan: NanPolicy,
        what: &str,
    ) -> Result<Vec<[f32; 2]>, FieldError> {
        let counts = self.dims.map(|n| (n - 1).div_ceil(brick));
        let span = |a: usize, b: usize| -> Range<i64> {
            let r = STENCIL.brick_points(b, brick, self.dims[a]);
            self.index(a, r.start)..self.index(a, r.end)
        };
        // The blocks along x and y the box meets: each brick layer looks its blocks up once
        // (a block is shared by up to 8 bricks), the one or two block layers along z it meets.
        let first = [0, 1].map(|a| self.index(a, 0).div_euclid(LEAF));
        let across = [0, 1]
            .map(|a| (self.index(a, self.dims[a] - 1).div_euclid(LEAF) - first[a] + 1) as usize);
        let layers: Vec<Result<Vec<[f32; 2]>, FieldError>> = (0..counts[2])
            .into_par_iter()
            .map(|bz| {
                let zs = span(2, bz);
                let table: Vec<(i64, Vec<Block>)> = blocks(zs.start, zs.end - 1)
                    .map(|oz| {
                        let row = (0..across[0] * across[1])
                            .map(|k| {
                                let bx = first[0] + (k % across[0]) as i64;
                                let by = first[1] + (k / across[0]) as i64;
                                self.block_at([bx * LEAF, by * LEAF, oz])
                            })
                            .collect();
                        (oz, row)
                    })
                    .collect();
                let mut out = Vec::with_capacity(counts[0] * counts[1]);
                for by in 0..counts[1] {
                    let ys = span(1, by);
                    for bx in 0..counts[0] {
                        let xs = span(0, bx);
                        let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
                        for (oz, row) in &table {
                            let oz = *oz;
                            for oy in blocks(ys.start, ys.end - 1) {
                                for ox in blocks(xs.start, xs.end - 1) {
                                    let k = (ox / LEAF - first[0]) as usize
                                        + across[0] * (oy / LEAF - first[1]) as usize;
                                    let block = row[k];
                                    let clip = |r: &Range<i64>, o: i64| {
                                        r.start.max(o)..r.end.min(o + LEAF)
                                    };
                                    let (cx, cy, cz) =
                                        (clip(&xs, ox), clip(&ys, oy), clip(&zs, oz));
                                    let check = |v: f32, p: [i64; 3]| {
                                        if nan == NanPolicy::Error && !v.is_finite() {
                                            return Err(FieldError::NonFinite {
                                                what: what.to_string(),
                                                index: [0, 1, 2].map(|a| {
                                                    (p[a] - i64::from(self.index_min[a])) as usize
                                                }),
                                                value: v,
                                                detail: String::new(),
                                            });
                                        }
                                        Ok(())
                                    };
                                    match block {
                                        Block::Value(v) => {
                                            check(v, [cx.start, cy.start, cz.start])?;
                                            widen(&mut mm, v);
                                        }
                                        Block::Leaf(_) => {
                                            for z in cz.clone() {
                                                for y in cy.clone() {
                                                    for x in cx.clone() {
                                                        let v = block.at([x, y, z]);
                                                        check(v, [x, y, z])?;
                                                        widen(&mut mm, v);
                                                    }
                                                }
                                            }
                                        }
                                    }
                                }
                            }
                        }
                        out.push(mm);
                    }
                }
                Ok(out)
            })
            .collect();
        let mut out = Vec::with_capacity(counts.iter().product());
        for layer in layers {
            out.extend(layer?);
        }
        Ok(out)
    }
}

/// Where a value checked under `field.nan = "error"` is refused: the grid's label and the
/// first voxel of the box (index coordinates of point 0).
struct Checked<'a> {
    nan: NanPolicy,
    what: &'a str,
    index_min: [i32; 3],
}

impl Checked<'_> {
    fn widen(&self, mm: &mut [f32; 2], v: f32, p: [i64; 3]) -> Result<(), FieldError> {
        if self.nan == NanPolicy::Error && !v.is_finite() {
            return Err(FieldError::NonFinite {
                what: self.what.to_string(),
                index: [0, 1, 2].map(|a| (p[a] - i64::from(self.index_min[a])) as usize),
                value: v,
                detail: String::new(),
            });
        }
        widen(mm, v);
        Ok(())
    }

    /// Widens `mm` by the values of `block` at the voxels `xs` × `ys` × `zs` (inside it).
    fn widen_block(
        &self,
        mm: &mut [f32; 2],
        block: Block<'_>,
        xs: Range<i64>,
        ys: Range<i64>,
        zs: Range<i64>,
    ) -> Result<(), FieldError> {
        match block {
            Block::Value(v) => self.widen(mm, v, [xs.start, ys.start, zs.start]),
            Block::Leaf(_) => {
                for z in zs {
                    for y in ys.clone() {
                        for x in xs.clone() {
                            self.widen(mm, block.at([x, y, z]), [x, y, z])?;
                        }
                    }
                }
                Ok(())
            }
        }
    }
}

/// The runs of `a .. b` (exclusive end) cut at multiples of `side`.
fn runs(a: i64, b: i64, side: i64) -> impl Iterator<Item = Range<i64>> {
    let first = a.div_euclid(side) * side;
    (first..b).step_by(side as usize).map(move |o| o.max(a)..(o + side).min(b))
}

impl SparseTree {
    /// The min/max of the points of every superbrick (`sup`³ bricks of `brick` cells, over the
    /// points its bricks read: the union of theirs), x fastest, `ceil(bricks / sup)` per axis:
    /// the smallest minimum and the largest maximum of its bricks' ranges, as
    /// `passes::bricks::levels` makes them. A 128³ region without a lower node is one value: one
    /// lookup for all of it, so empty space costs a lookup per region, not per voxel.
    pub fn super_ranges(
        &self,
        brick: usize,
        sup: usize,
        nan: NanPolicy,
        what: &str,
    ) -> Result<Vec<[f32; 2]>, FieldError> {
        let bricks = self.dims.map(|n| (n - 1).div_ceil(brick));
        let supers = bricks.map(|n| n.div_ceil(sup));
        let span = |a: usize, s: usize| -> Range<i64> {
            let first = STENCIL.brick_points(s * sup, brick, self.dims[a]).start;
            let last = ((s + 1) * sup).min(bricks[a]) - 1;
            let end = STENCIL.brick_points(last, brick, self.dims[a]).end;
            self.index(a, first)..self.index(a, end)
        };
        let checked = Checked { nan, what, index_min: self.index_min };
        let layers: Vec<Result<Vec<[f32; 2]>, FieldError>> = (0..supers[2])
            .into_par_iter()
            .map(|sz| {
                let mut out = Vec::with_capacity(supers[0] * supers[1]);
                for sy in 0..supers[1] {
                    for sx in 0..supers[0] {
                        let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
                        self.widen_box(&checked, &mut mm, [span(0, sx), span(1, sy), span(2, sz)])?;
                        out.push(mm);
                    }
                }
                Ok(out)
            })
            .collect();
        let mut out = Vec::with_capacity(supers.iter().product());
        for layer in layers {
            out.extend(layer?);
        }
        Ok(out)
    }

    /// The min/max of brick `b`'s points (bricks of `brick` cells), as
    /// [`SparseTree::brick_ranges`] gives it.
    pub fn brick_range(
        &self,
        b: [usize; 3],
        brick: usize,
        nan: NanPolicy,
        what: &str,
    ) -> Result<[f32; 2], FieldError> {
        let span = |a: usize| {
            let r = STENCIL.brick_points(b[a], brick, self.dims[a]);
            self.index(a, r.start)..self.index(a, r.end)
        };
        let checked = Checked { nan, what, index_min: self.index_min };
        let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
        self.widen_box(&checked, &mut mm, [span(0), span(1), span(2)])?;
        Ok(mm)
    }

    /// Widens `mm` by the voxels of the box `r` (index coordinates, exclusive ends).
    fn widen_box(
        &self,
        checked: &Checked,
        mm: &mut [f32; 2],
        r: [Range<i64>; 3],
    ) -> Result<(), FieldError> {
        let side = i64::from(LOWER);
        for rz in runs(r[2].start, r[2].end, side) {
            for ry in runs(r[1].start, r[1].end, side) {
                for rx in runs(r[0].start, r[0].end, side) {
                    let origin =
                        [rx.start, ry.start, rz.start].map(|c| (c.div_euclid(side) * side) as i32);
                    if !self.tree.has_lower(origin) {
                        let block = self.tree.block(origin);
                        checked.widen_block(
                            mm,
                            block,
                            rx.start..rx.start + 1,
                            ry.start..ry.start + 1,
                            rz.start..rz.start + 1,
                        )?;
                        continue;
                    }
                    for bz in runs(rz.start, rz.end, LEAF) {
                        for by in runs(ry.start, ry.end, LEAF) {
                            for bx in runs(rx.start, rx.end, LEAF) {
                                let block = self.block_at([bx.start, by.start, bz.start]);
                                checked.widen_block(
                                    mm,
                                    block,
                                    bx.clone(),
                                    by.clone(),
                                    bz.clone(),
                                )?;
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tree with one leaf, one lower-node tile and one upper-node tile, over a buffer laid
    /// out as the OpenVDB reader's records (4-byte entries).
    fn tree() -> (NodeTree, Vec<f32>) {
        let leaf: Vec<f32> = (0..512).map(|n| n as f32).collect();
        let mut lower = vec![-3f32; 4096];
        lower[(1 << 8) | (2 << 4) | 3] = 7.0; // the block at (8, 16, 24) of the node
        let upper = vec![-5f32; 32768];
        let mut buf = Vec::new();
        for v in leaf.iter().chain(&lower).chain(&upper) {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        let mut t = NodeTree::new(buf, 9.0, 4);
        t.add_leaf([-8, 0, 0], 0).unwrap();
        t.add_lower([-128, 0, 0], 2048).unwrap();
        t.add_upper([-4096, 0, 0], 2048 + 4 * 4096).unwrap();
        t.add_root_tile([0, 4096, 0], 2.0).unwrap();
        (t, leaf)
    }

    #[test]
    fn blocks_follow_openvdb_get_value() {
        let (t, leaf) = tree();
        // The leaf: voxel (-8 + x, y, z) at x << 6 | y << 3 | z.
        let b = t.block([-8, 0, 0]);
        assert_eq!(b.at([-8 + 3, 4, 5]), leaf[(3 << 6) | (4 << 3) | 5]);
        assert_eq!(b.at([-1, 7, 7]), 511.0);
        // The lower node's tiles: its block (8, 16, 24) from the node's origin, and the rest.
        assert!(matches!(t.block([-128 + 8, 16, 24]), Block::Value(v) if v == 7.0));
        assert!(matches!(t.block([-16, 0, 0]), Block::Value(v) if v == -3.0));
        // The upper node's tile, a root tile, the background.
        assert!(matches!(t.block([-256, 0, 0]), Block::Value(v) if v == -5.0));
        assert!(matches!(t.block([8, 4096 + 8, 16]), Block::Value(v) if v == 2.0));
        assert!(matches!(t.block([8, 0, 0]), Block::Value(v) if v == 9.0));
    }

    #[test]
    fn nodes_off_their_lattice_or_past_the_buffer_are_refused() {
        let (mut t, _) = tree();
        assert!(t.add_leaf([-4, 0, 0], 0).unwrap_err().contains("lattice"));
        assert!(t.add_leaf([0, 0, 0], t.buffer().len() - 100).unwrap_err().contains("past"));
        assert!(t.add_lower([0, 0, 0], usize::MAX - 4).unwrap_err().contains("past"));
    }

    /// Reads and ranges of boxes straddling the leaf, the tiles and the background equal a
    /// point-by-point lookup of the same voxels.
    #[test]
    fn boxes_and_brick_ranges_equal_point_lookups() {
        let (t, _) = tree();
        let sparse = SparseTree { tree: Arc::new(t), index_min: [-21, -3, -6], dims: [30, 13, 17] };
        let value = |p: [usize; 3]| {
            let o = [0, 1, 2].map(|a| i64::from(sparse.index_min[a]) + p[a] as i64);
            sparse.block_at(o).at(o)
        };
        let all = sparse.dense();
        let d = sparse.dims;
        for z in 0..d[2] {
            for y in 0..d[1] {
                for x in 0..d[0] {
                    assert_eq!(all[x + d[0] * (y + d[1] * z)], value([x, y, z]));
                }
            }
        }
        let dense_ranges = sparse.brick_ranges(8, NanPolicy::Error, "t").unwrap();
        let counts = d.map(|n| (n - 1).div_ceil(8));
        for bz in 0..counts[2] {
            for by in 0..counts[1] {
                for bx in 0..counts[0] {
                    let got = sparse.brick_range([bx, by, bz], 8, NanPolicy::Error, "t").unwrap();
                    assert_eq!(got, dense_ranges[bx + counts[0] * (by + counts[1] * bz)]);
                }
            }
        }
        // Superbricks of 2^3 bricks: the union of their bricks' ranges.
        let supers = sparse.super_ranges(8, 2, NanPolicy::Error, "t").unwrap();
        let sc = counts.map(|n| n.div_ceil(2));
        for sz in 0..sc[2] {
            for sy in 0..sc[1] {
                for sx in 0..sc[0] {
                    let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
                    for bz in 2 * sz..(2 * sz + 2).min(counts[2]) {
                        for by in 2 * sy..(2 * sy + 2).min(counts[1]) {
                            for bx in 2 * sx..(2 * sx + 2).min(counts[0]) {
                                let r = dense_ranges[bx + counts[0] * (by + counts[1] * bz)];
                                mm = [mm[0].min(r[0]), mm[1].max(r[1])];
                            }
                        }
                    }
                    assert_eq!(
                        supers[sx + sc[0] * (sy + sc[1] * sz)],
                        mm,
                        "superbrick {sx} {sy} {sz}"
                    );
                }
            }
        }
        let part = sparse.read_box([5, 2, 3], [9, 4, 11]);
        assert_eq!(part[1 + 9 * (2 + 4 * 3)], value([6, 4, 6]));
        let ranges = sparse.brick_ranges(8, NanPolicy::Error, "t").unwrap();
        let counts = d.map(|n| (n - 1).div_ceil(8));
        for bz in 0..counts[2] {
            for by in 0..counts[1] {
                for bx in 0..counts[0] {
                    let mut mm = [f32::INFINITY, f32::NEG_INFINITY];
                    for z in STENCIL.brick_points(bz, 8, d[2]) {
                        for y in STENCIL.brick_points(by, 8, d[1]) {
                            for x in STENCIL.brick_points(bx, 8, d[0]) {
                                widen(&mut mm, value([x, y, z]));
                            }
                        }
                    }
                    let at = bx + counts[0] * (by + counts[1] * bz);
                    assert_eq!(ranges[at], mm, "brick {bx} {by} {bz}");
                }
            }
        }
    }
}
