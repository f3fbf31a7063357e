//! What the extraction shaders read besides their buffers: the `Params` uniform
//! ([`ExtractParams`]), the push constants of the slab passes ([`SlabPush`]), the lookup tables
//! ([`ExtractTables`], the CPU reference's own arrays), the modes of `classify.comp`, and the
//! f32 threshold that makes the shaders' inside test the f64 reference's
//! ([`inside_threshold`]). Each struct mirrors its GLSL declaration; the sizes and offsets are
//! asserted here and checked on the GPU by `tests/it/gpu/layout.rs`.

use bytemuck::{Pod, Zeroable};

use crate::mesh::tables;

/// std140 mirror of `Params` in `shaders/extract/common.glsl` (vec4 members only, so std140 is
/// the C layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ExtractParams {
    /// Grid points per axis; w: padding layers (1 for dual contouring, else 0).
    pub dims: [i32; 4],
    /// World position of grid point (0, 0, 0).
    pub box_min: [f32; 4],
    /// World size of one cell.
    pub spacing: [f32; 4],
    /// x: inside threshold (see [`inside_threshold`]); y, z: the isovalue as f32 hi + lo; w: +1
    /// for inside = below, -1 for above.
    pub iso: [f32; 4],
    /// x, y: the bits of the f64 isovalue, low word first (`packDouble2x32`); the mc33 passes
    /// decide topology in f64 as the CPU reference does. z: `dual-contouring-qef` flags (bit 0
    /// on, bit 1 clamp into the cell), w: its singular-value threshold's f32 bits.
    pub iso_bits: [u32; 4],
}

const _: () = {
    assert!(std::mem::size_of::<ExtractParams>() == 80);
    assert!(std::mem::offset_of!(ExtractParams, iso) == 48);
    assert!(std::mem::offset_of!(ExtractParams, iso_bits) == 64);
};

/// Push constants of the extraction passes (`Push` in `common.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SlabPush {
    /// Workgroups along x of the dispatch (1D work spread over x and y).
    pub groups_x: u32,
    /// Items (points, cells, vertices or triangles) in the dispatch.
    pub count: u32,
    /// Padded z layer of the first item.
    pub z0: i32,
    /// Padded point layer of the slab's first point.
    pub point_z0: i32,
    /// Padded cell layer of the slab's first cell.
    pub cell_z0: i32,
    /// Slab index of the first point the slab owns.
    pub owned_point: u32,
    /// Slab index of the first cell the slab owns.
    pub owned_cell: u32,
    /// Global id of the slab's first vertex.
    pub vertex_base: u32,
    /// Pass-specific mode.
    pub mode: u32,
    /// Padded point layer of the slab's first sample in the values buffer.
    pub value_z0: i32,
    /// Slab index one past the last point the slab owns.
    pub owned_point_end: u32,
    /// Slab index one past the last cell the slab owns.
    pub owned_cell_end: u32,
    /// MC33: global number of the slab's first added vertex (among all added vertices).
    pub added_base: u32,
    /// MC33: where the slab's added vertices start in its output (after its edge vertices).
    pub added_offset: u32,
}

const _: () = assert!(std::mem::size_of::<SlabPush>() == 56);

/// The lookup tables of [`crate::mesh::tables`] as the shaders read them: `Tables` in
/// `common.glsl`, std430 arrays of `int` (stride 4, so the C layout).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct ExtractTables {
    pub mc_triangles: [[i32; 16]; 256],
    pub mc_edges: [[i32; 2]; 12],
    pub mc_vertex_corner: [i32; 8],
    pub mt_tets: [[i32; 4]; 6],
    pub mt_tet_edges: [[i32; 2]; 6],
    pub mt_triangles: [[i32; 6]; 16],
    /// `mc_edge_index[8 a + b]`: the Bourke number of the cell edge between corners `a` and
    /// `b`, -1 where they share no edge (MC33's face walks).
    pub mc_edge_index: [i32; 64],
}

const _: () = {
    assert!(std::mem::offset_of!(ExtractTables, mc_edges) == 256 * 16 * 4);
    assert!(std::mem::offset_of!(ExtractTables, mc_vertex_corner) == (4096 + 24) * 4);
    assert!(std::mem::offset_of!(ExtractTables, mt_tets) == (4096 + 24 + 8) * 4);
    assert!(std::mem::offset_of!(ExtractTables, mt_tet_edges) == (4096 + 24 + 8 + 24) * 4);
    assert!(std::mem::offset_of!(ExtractTables, mt_triangles) == (4096 + 24 + 8 + 24 + 12) * 4);
    assert!(
        std::mem::offset_of!(ExtractTables, mc_edge_index) == (4096 + 24 + 8 + 24 + 12 + 96) * 4
    );
    assert!(std::mem::size_of::<ExtractTables>() == (4096 + 24 + 8 + 24 + 12 + 96 + 64) * 4);
};

impl ExtractTables {
    /// The very arrays the CPU reference uses, widened to `i32`.
    pub fn new() -> Self {
        let mut t = ExtractTables::zeroed();
        for (row, src) in t.mc_triangles.iter_mut().zip(&tables::MC_TRIANGLES) {
            *row = src.map(i32::from);
        }
        for (e, &(corner, axis)) in t.mc_edges.iter_mut().zip(&tables::MC_EDGES) {
            *e = [i32::from(corner), i32::from(axis)];
        }
        t.mc_vertex_corner = tables::MC_VERTEX_CORNER.map(i32::from);
        for (tet, src) in t.mt_tets.iter_mut().zip(&tables::MT_TETS) {
            *tet = src.map(i32::from);
        }
        for (e, &(a, b)) in t.mt_tet_edges.iter_mut().zip(&tables::MT_TET_EDGES) {
            *e = [i32::from(a), i32::from(b)];
        }
        for (row, src) in t.mt_triangles.iter_mut().zip(&tables::MT_TRIANGLES) {
            *row = src.map(i32::from);
        }
        t.mc_edge_index = [-1; 64];
        for (e, &(corner, axis)) in tables::MC_EDGES.iter().enumerate() {
            let (a, b) = (usize::from(corner), usize::from(corner | (1 << axis)));
            t.mc_edge_index[8 * a + b] = e as i32;
            t.mc_edge_index[8 * b + a] = e as i32;
        }
        t
    }
}

impl Default for ExtractTables {
    fn default() -> Self {
        Self::new()
    }
}

/// The f32 threshold `t` for which `v < t` (inside = below) or `v > t` (above) equals the f64
/// comparison of every f32 `v` with `iso`: the smallest f32 ≥ `iso` for below, the largest
/// f32 ≤ `iso` for above (infinite beyond the f32 range).
pub fn inside_threshold(iso: f64, below: bool) -> f32 {
    let t = iso as f32; // round to nearest
    let t64 = f64::from(t);
    if below && t64 < iso {
        next_toward(t, 1.0)
    } else if !below && t64 > iso {
        next_toward(t, -1.0)
    } else {
        t
    }
}

/// The f32 after finite `t` in the direction of `sign` (`f32::next_up` / `next_down`, which
/// need a newer Rust than the crate's minimum).
fn next_toward(t: f32, sign: f32) -> f32 {
    if t == 0.0 {
        return f32::from_bits(1).copysign(sign);
    }
    let bits = t.to_bits();
    if (t > 0.0) == (sign > 0.0) {
        f32::from_bits(bits + 1)
    } else {
        f32::from_bits(bits - 1)
    }
}

/// Modes of `classify.comp`.
pub mod classify_mode {
    use crate::shaders::consts;
    pub const MC: u32 = consts::MODE_MC;
    pub const MT: u32 = consts::MODE_MT;
    pub const DUAL: u32 = consts::MODE_DUAL;
    pub const MC33: u32 = consts::MODE_MC33;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inside_threshold_reproduces_the_f64_comparison() {
        let isos = [0.1, -0.1, 0.0, 1.0 / 3.0, 1e-40, -1e-40, 1e39, -1e39, 0.5, 16777217.0];
        for &iso in &isos {
            let t_below = inside_threshold(iso, true);
            let t_above = inside_threshold(iso, false);
            let near = iso as f32;
            let (up, down) = (next_toward(near, 1.0), next_toward(near, -1.0));
            let mut vs = vec![near, up, down, 0.0, -0.0, 1.0, -1.0, f32::from_bits(1)];
            vs.extend([f32::MAX, f32::MIN, f32::INFINITY, f32::NEG_INFINITY]);
            for v in vs {
                assert_eq!(v < t_below, f64::from(v) < iso, "below iso {iso} v {v}");
                assert_eq!(v > t_above, f64::from(v) > iso, "above iso {iso} v {v}");
            }
        }
    }

    #[test]
    fn next_toward_steps_one_ulp() {
        assert_eq!(next_toward(1.0, 1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_toward(1.0, -1.0), 1.0 - f32::EPSILON / 2.0);
        assert_eq!(next_toward(-1.0, 1.0), -1.0 + f32::EPSILON / 2.0);
        assert_eq!(next_toward(0.0, -1.0), -f32::from_bits(1));
    }

    #[test]
    fn tables_widen_the_cpu_tables() {
        let t = ExtractTables::new();
        assert_eq!(t.mc_triangles[1][..4], [0, 8, 3, -1]);
        assert_eq!(t.mc_edges[11], [2, 2]);
        assert_eq!(t.mt_tets[5], [0, 6, 4, 7]);
        assert_eq!(t.mt_triangles[3], [1, 2, 4, 1, 4, 3]);
    }
}
