#version 450
// Extraction pass `edge vertices` (marching cubes, marching tetrahedra): one vertex per crossed
// lattice edge, numbered by the scanned point counts, so in increasing edge id
// `families * p + f` (`mesh/edges.rs`).
//
// One invocation per vertex of the slab (mode 0: families x, y, z; mode 1: the 7 MT
// families): vertex v belongs to the owned point p with scan[p] <= v < scan[p + 1] (relative
// to the first owned point), and is its rank-th crossed edge; position at the crossing, normal
// from the gradient.

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

#include "common.glsl"

void main() {
    uint v = item_index();
    if (v >= C.count) {
        return;
    }
    uint rank;
    uint slot = find_point(v, rank);
    ivec3 q = point_at(slot);
    uint mask = point_mask[slot];
    uint families = C.mode == 1u ? 7u : 3u;
    // The rank-th crossed family of the point.
    uint f = 0u;
    for (uint seen = 0u; f < families; f++) {
        if ((mask & (1u << f)) != 0u) {
            if (seen == rank) {
                break;
            }
            seen++;
        }
    }
    bool in_q = (mask & INSIDE_BIT) != 0u;
    ivec3 d = offset_of(C.mode == 1u ? f + 1u : 1u << f);
    float s = crossing(value_at(q), value_at(q + d));
    vec3 local = s * vec3(d);
    vec3 out_dir = in_q ? vec3(d) : -vec3(d);
    positions[v] = vec4(world(q, local), 1.0);
    normals[v] = vec4(normal_at(q, local, out_dir), 0.0);
}
