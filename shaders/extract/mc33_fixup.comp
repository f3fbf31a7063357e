#version 450
// Extraction pass `mc33 fixup`: added-vertex placeholders -> final vertex ids, once every slab
// is emitted. Added vertex a (counted over the whole grid in cell order) is referred to as
// u32::MAX - a while the edge vertices are still being counted; its id is edges + a, after all
// of them, as in the CPU reference.
//
// One dispatch per slab, one invocation per index of the slab's triangles (a slab's buffers
// fit one binding; the assembled mesh's need not). Push constants: count = the slab's indices,
// vertex_base = edge vertices of the whole mesh, added_base = added vertices of the whole mesh
// (the mesh has fewer than u32::MAX vertices, so no edge vertex id reaches the placeholders).

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

#include "common.glsl"

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    uint x = indices[id];
    if (C.added_base > 0u && x > 0xFFFFFFFFu - C.added_base) {
        indices[id] = C.vertex_base + (0xFFFFFFFFu - x);
    }
}
