#version 450
// Extraction pass `edge vertices` (marching cubes, marching tetrahedra): one vertex per crossed
// lattice edge, numbered by the scanned point counts, so in increasing edge id
// `families * p + f` (`mesh/edges.rs`).
//
// One invocation per point the slab owns (mode 0: families x, y, z; mode 1: the 7 MT
// families). Vertex `point_scan[slot] - point_scan[owned_point] + rank` of the slab, where rank
// counts the crossed families below f; position at the crossing, normal from the gradient.

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = 64) in;

#include "common.glsl"

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    ivec3 q = item_coords(id, np().xy);
    uint slot = point_slot(q);
    uint mask = point_mask[slot];
    if ((mask & EDGE_BITS) == 0u) {
        return;
    }
    uint v = point_scan[slot] - point_scan[C.owned_point];
    bool in_q = (mask & INSIDE_BIT) != 0u;
    float va = value_at(q);
    uint families = C.mode == 1u ? 7u : 3u;
    for (uint f = 0u; f < families; f++) {
        if ((mask & (1u << f)) == 0u) {
            continue;
        }
        ivec3 d = offset_of(C.mode == 1u ? f + 1u : 1u << f);
        float s = crossing(va, value_at(q + d));
        vec3 local = s * vec3(d);
        vec3 out_dir = in_q ? vec3(d) : -vec3(d);
        positions[v] = vec4(world(q, local), 1.0);
        normals[v] = vec4(normal_at(q, local, out_dir), 0.0);
        v++;
    }
}
