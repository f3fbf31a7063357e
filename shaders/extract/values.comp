#version 450
// Extraction pass `values`: copy the samples of the slab's padded point layers from the grid
// image into the `values` buffer (0 at padding points), one texelFetch per point, so the other
// passes read a plain storage buffer (several times faster than image fetches on lavapipe).
//
// One invocation per padded point of layers C.value_z0 ... (C.z0 = C.value_z0).

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

#include "common.glsl"

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    ivec3 n = np();
    ivec3 q = item_coords(id, n.xy);
    values[q.x + n.x * (q.y + n.y * (q.z - C.value_z0))] =
        is_real(q) ? texelFetch(u_grid, q - pad(), 0).r : 0.0;
}
