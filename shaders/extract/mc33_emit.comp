#version 450
// Extraction pass `mc33 emit`: the triangles and added vertices of each cell (`mesh/mc33.rs`).
//
// One invocation per triangle of the slab; the invocation of a cell's first triangle builds the
// cell's surface once and writes all its triangles and added vertices (the others return), so
// the work still follows the output. Edge vertices are the marching-cubes ones (`edge
// vertices` pass); added vertices go after the slab's edge vertices in its output, and the
// triangles refer to them by placeholder (see `vertex_id` in mc33.glsl).

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = 64) in;

#include "common.glsl"
#include "mc33.glsl"

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    uint rank;
    uint slot = find_cell(id, rank);
    if (rank != 0u) {
        return;
    }
    uint added = added_scan[slot] - added_scan[C.owned_cell];
    WRITE = true;
    TRI_OUT = id;
    ADDED_ID = C.added_base + added;
    ADDED_OUT = C.added_offset + added;
    cell_mesh(cell_at(slot));
}
