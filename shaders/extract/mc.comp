#version 450
// Extraction pass `marching cubes`: triangles of each cell from Bourke's table (`mesh/mc.rs`).
//
// One invocation per cell the slab owns. The case comes from the inside bits of the 8 corner
// points' masks. Mode 0 writes the cell's triangle count; mode 1 (after the scan) writes its
// triangles from `cell_scan[slot] - cell_scan[owned_cell]` on, each table triple (e0, e1, e2)
// as (v(e0), v(e2), v(e1)): counter-clockwise seen from outside.

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = 64) in;

#include "common.glsl"

// Global id of the vertex on the lattice edge from point q along axis.
uint edge_vertex(ivec3 q, uint axis) {
    uint slot = point_slot(q);
    uint below = point_mask[slot] & ((1u << axis) - 1u);
    return C.vertex_base + point_scan[slot] - point_scan[C.owned_point] + bitCount(below);
}

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    ivec3 c = item_coords(id, nc().xy);
    uint cube = 0u;
    for (int b = 0; b < 8; b++) {
        ivec3 q = c + offset_of(uint(mc_vertex_corner[b]));
        if ((point_mask[point_slot(q)] & INSIDE_BIT) != 0u) {
            cube |= 1u << b;
        }
    }
    int row = int(cube) * 16;
    uint slot = cell_slot(c);
    if (C.mode == 0u) {
        uint n = 0u;
        while (n < 15u && mc_triangles[row + int(n)] >= 0) {
            n += 3u;
        }
        cell_scan[slot] = n / 3u;
        return;
    }
    uint t = cell_scan[slot] - cell_scan[C.owned_cell];
    for (int n = 0; n < 15 && mc_triangles[row + n] >= 0; n += 3) {
        uint v[3];
        for (int e = 0; e < 3; e++) {
            int edge = mc_triangles[row + n + e];
            v[e] = edge_vertex(c + offset_of(uint(mc_edges[2 * edge])),
                               uint(mc_edges[2 * edge + 1]));
        }
        indices[3u * t] = v[0];
        indices[3u * t + 1u] = v[2];
        indices[3u * t + 2u] = v[1];
        t++;
    }
}
