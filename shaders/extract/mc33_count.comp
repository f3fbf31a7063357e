#version 450
// Extraction pass `mc33 count`: the triangles and added vertices of each crossed cell of the
// slab (`mesh/mc33.rs`), after `classify` (mode mc33: 1 per crossed cell) and the cell scan.
//
// One invocation per crossed cell (the i-th by the scan): tri_scan[i] gets its triangle count,
// added_scan[i] its added-vertex count; both are scanned next. Only crossed cells run this
// large shader: lavapipe pays a fixed cost per invocation of it even on a path that skips the
// work, so a dispatch over every cell took ten times the marching-cubes time.

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
    WRITE = false;
    cell_mesh(cell_at(find_cell(id, rank)));
    tri_scan[id] = NTRI;
    added_scan[id] = uint(NADDED);
}
