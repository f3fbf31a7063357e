#version 450
// Extraction pass `marching tetrahedra`: triangles of the 6 tetrahedra of each cell
// (`mesh/mt.rs`).
//
// Mode 0, one invocation per cell the slab owns: the cell's triangle count. Mode 1 (after the
// scan), one invocation per triangle of the slab: finds its cell and rank there (bisection of
// the scan) and writes it; a cell's triangles go tetrahedra in table order.

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = 64) in;

#include "common.glsl"

// Global id of the vertex on the lattice edge between cell corners a and b, which runs from the
// corner whose offset bits are a subset of the other's.
uint corner_edge_vertex(ivec3 c, uint a, uint b) {
    uint lo = (a & b) == a ? a : b;
    uint hi = lo == a ? b : a;
    uint family = (lo ^ hi) - 1u;
    uint slot = point_slot(c + offset_of(lo));
    uint below = point_mask[slot] & ((1u << family) - 1u);
    return C.vertex_base + point_scan[slot] - point_scan[C.owned_point] + bitCount(below);
}

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    bool emit = C.mode == 1u;
    uint rank = 0u;
    ivec3 c = emit ? cell_at(find_cell(id, rank)) : item_coords(id, nc().xy);
    uint mask = 0u;
    for (int n = 0; n < 8; n++) {
        if ((point_mask[point_slot(c + offset_of(uint(n)))] & INSIDE_BIT) != 0u) {
            mask |= 1u << n;
        }
    }
    // Count the cell's triangles; in mode 1 stop at triangle `rank` and write it as `id`.
    uint t = 0u;
    if (mask != 0u && mask != 255u) {
        for (int tet = 0; tet < 6; tet++) {
            uint tcase = 0u;
            for (int l = 0; l < 4; l++) {
                if ((mask & (1u << uint(mt_tets[4 * tet + l]))) != 0u) {
                    tcase |= 1u << l;
                }
            }
            int row = int(tcase) * 6;
            for (int n = 0; n < 6 && mt_triangles[row + n] >= 0; n += 3) {
                if (emit && t == rank) {
                    for (int e = 0; e < 3; e++) {
                        int edge = mt_triangles[row + n + e];
                        uint a = uint(mt_tets[4 * tet + mt_tet_edges[2 * edge]]);
                        uint b = uint(mt_tets[4 * tet + mt_tet_edges[2 * edge + 1]]);
                        indices[3u * id + uint(e)] = corner_edge_vertex(c, a, b);
                    }
                    return;
                }
                t++;
            }
        }
    }
    if (!emit) {
        cell_scan[cell_slot(c)] = t;
    }
}
