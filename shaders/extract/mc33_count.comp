#version 450
// Extraction pass `mc33 count`: the triangles and added vertices of each cell of the slab
// (`mesh/mc33.rs`), after `classify` (mode marching cubes) has written the point masks.
//
// One invocation per cell of the slab's cell layers: cell_scan gets its triangle count (over
// what classify wrote there), added_scan its added-vertex count; both are scanned next.

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = 64) in;

#include "common.glsl"
#include "mc33.glsl"

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    ivec3 c = item_coords(id, nc().xy);
    uint slot = cell_slot(c);
    uint mask = cell_corner_mask(c);
    uint tris = 0u;
    uint added = 0u;
    if (mask != 0u && mask != 255u) {
        WRITE = false;
        cell_mesh(c);
        tris = NTRI;
        added = uint(NADDED);
    }
    cell_scan[slot] = tris;
    added_scan[slot] = added;
}
