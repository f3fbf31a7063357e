#version 450
// Extraction pass `marching tetrahedra`: triangles of the 6 tetrahedra of each cell
// (`mesh/mt.rs`).
//
// One invocation per triangle of the slab (the classify pass counted them per cell): finds its
// cell and rank there (bisection of the scan) and writes it; a cell's triangles go tetrahedra
// in table order.

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

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
    uint rank;
    ivec3 c = cell_at(find_cell(id, rank));
    uint mask = 0u;
    for (int n = 0; n < 8; n++) {
        if ((point_mask[point_slot(c + offset_of(uint(n)))] & INSIDE_BIT) != 0u) {
            mask |= 1u << n;
        }
    }
    // Walk the cell's triangles to triangle `rank`; write it as `id`.
    uint t = 0u;
    for (int tet = 0; tet < 6; tet++) {
        uint tcase = 0u;
        for (int l = 0; l < 4; l++) {
            if ((mask & (1u << uint(mt_tets[4 * tet + l]))) != 0u) {
                tcase |= 1u << l;
            }
        }
        int row = int(tcase) * 6;
        for (int n = 0; n < 6 && mt_triangles[row + n] >= 0; n += 3) {
            if (t == rank) {
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
