#version 450
// Extraction pass `marching cubes`: triangles of each cell from Bourke's table (`mesh/mc.rs`).
//
// One invocation per triangle of the slab (the classify pass counted them per cell): finds its
// cell and rank there (bisection of the scan), the case from the inside bits of the 8 corner
// points' masks, and writes the table triple (e0, e1, e2) as (v(e0), v(e2), v(e1)):
// counter-clockwise seen from outside.

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

#include "common.glsl"

// The Bourke case of cell c from its corners' inside bits.
uint cube_of(ivec3 c) {
    uint cube = 0u;
    for (int b = 0; b < 8; b++) {
        ivec3 q = c + offset_of(uint(mc_vertex_corner[b]));
        if ((point_mask[point_slot(q)] & INSIDE_BIT) != 0u) {
            cube |= 1u << b;
        }
    }
    return cube;
}

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    // Triangle `id` of the slab is triangle `rank` of its cell.
    uint rank;
    ivec3 c = cell_at(find_cell(id, rank));
    int n = int(cube_of(c)) * 16 + 3 * int(rank);
    uint v[3];
    for (int e = 0; e < 3; e++) {
        int edge = mc_triangles[n + e];
        v[e] = edge_vertex(c + offset_of(uint(mc_edges[2 * edge])), uint(mc_edges[2 * edge + 1]));
    }
    indices[3u * id] = v[0];
    indices[3u * id + 1u] = v[2];
    indices[3u * id + 2u] = v[1];
}
