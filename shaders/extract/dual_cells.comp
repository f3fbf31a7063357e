#version 450
// Extraction pass `dual cells` (surface nets, dual contouring): one vertex per active padded
// cell, numbered in increasing cell number by the scan (`mesh/dual.rs`).
//
// One invocation per vertex of the slab (the classify pass flagged the active cells): find its
// cell (bisection of the scan), write the vertex at the mean of the edge crossings with the
// field's normal there, or, for a padding cell of dual contouring, the box's outward normal.

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

#include "common.glsl"
#include "dual.glsl"

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    ivec3 cells = nc();
    // Vertex `id` of the slab belongs to the active cell found by bisection of the scan.
    uint v = id;
    uint rank;
    ivec3 c = cell_at(find_cell(v, rank));
    CellVertex cv;
    cell_vertex(c, cv);
    positions[v] = vec4(cell_vertex_world(c, cv), 1.0);
    vec3 box = vec3(0.0);
    if (pad() > 0) {
        box = mix(vec3(0.0), vec3(-1.0), equal(c, ivec3(0)));
        box = mix(box, vec3(1.0), equal(c, cells - 1));
    }
    // dual-contouring-qef: the normal at the vertex clamped into its cell (an unclamped vertex
    // may leave it; the slab holds the samples of its own cells only), as `dual.rs` does.
    ivec3 base = c - pad();
    vec3 local = qef_on() ? clamp(cv.local, vec3(0.0), vec3(1.0)) : cv.local;
    vec3 normal = box != vec3(0.0) ? normalize(box) : normal_at(base, local, cv.fallback);
    normals[v] = vec4(normal, 0.0);
}
