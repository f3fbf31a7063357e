#version 450
// Extraction pass `mc33 emit`: the triangles and added vertices of each crossed cell
// (`mesh/mc33.rs`).
//
// One invocation per crossed cell (the i-th by the cell scan): builds the cell's surface again
// and writes its triangles from tri_scan[i] and its added vertices from added_scan[i], after
// the slab's edge vertices in its output. Edge vertices are the marching-cubes ones (`edge
// vertices` pass); triangles refer to added vertices by placeholder (see `vertex_id` in
// mc33.glsl).

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

#include "common.glsl"
#include "mc33.glsl"

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    uint rank;
    uint slot = find_cell(id, rank);
    WRITE = true;
    TRI_OUT = tri_scan[id];
    ADDED_ID = C.added_base + added_scan[id];
    ADDED_OUT = C.added_offset + added_scan[id];
    cell_mesh(cell_at(slot));
}
