#version 450
// Extraction pass `dual quads` (surface nets, dual contouring): one quad per crossed lattice
// edge with four cells around it, in increasing edge id, as two consecutive triangles
// (`mesh/dual.rs`).
//
// One invocation per quad of the slab: its point (bisection of the scan of the quad counts of
// the points pass) and rank there give the edge. For the edge
// along axis a, with (b, c) = (a + 1, a + 2) mod 3, the cells at offsets (-1,-1), (0,-1),
// (0,0), (-1,0) along (b, c) make q0..q3, counter-clockwise about +a, reversed (q1 <-> q3) if
// the edge starts outside. Mode 0 splits along q0-q2; mode 1 along the shorter diagonal
// (q0-q2 when |q2 - q0|² <= |q3 - q1|², else q1-q3).

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

#include "common.glsl"
#include "dual.glsl"

uint cell_id(ivec3 c) {
    return C.vertex_base + cell_scan[cell_slot(c)] - cell_scan[C.owned_cell];
}

// World position of active cell c's vertex: written by the dual cells pass for the cells this
// slab owns (layers from C.z0); recomputed, by the same code, for the layer before them.
vec3 cell_position(ivec3 c) {
    if (c.z >= C.z0) {
        return positions[cell_scan[cell_slot(c)] - cell_scan[C.owned_cell]].xyz;
    }
    CellVertex cv;
    cell_vertex(c, cv);
    return cell_vertex_world(c, cv);
}

float dist2(vec3 a, vec3 b) {
    vec3 d = a - b;
    return dot(d, d);
}

void main() {
    uint quad = item_index();
    if (quad >= C.count) {
        return;
    }
    // Quad `quad` of the slab is quad `rank` of its point (bisection of the scan).
    uint rank;
    uint slot = find_point(quad, rank);
    ivec3 q = point_at(slot);
    uint mask = point_mask[slot];
    ivec3 cells = nc();
    uint seen = 0u;
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3;
        int c = (a + 2) % 3;
        if ((mask & (1u << a)) == 0u || q[b] < 1 || q[c] < 1 || q[b] >= cells[b]
            || q[c] >= cells[c] || (mask & (RING_MISSING << a)) != 0u) {
            continue;
        }
        if (seen++ != rank) {
            continue;
        }
        ivec3 eb = ivec3(0);
        eb[b] = 1;
        ivec3 ec = ivec3(0);
        ec[c] = 1;
        ivec3 corner[4] = ivec3[4](q - eb - ec, q - ec, q, q - eb);
        if ((mask & INSIDE_BIT) == 0u) {
            ivec3 t = corner[1];
            corner[1] = corner[3];
            corner[3] = t;
        }
        uint v[4];
        for (int i = 0; i < 4; i++) {
            v[i] = cell_id(corner[i]);
        }
        bool along_02 = true;
        if (C.mode == 1u) {
            vec3 p0 = cell_position(corner[0]);
            vec3 p1 = cell_position(corner[1]);
            vec3 p2 = cell_position(corner[2]);
            vec3 p3 = cell_position(corner[3]);
            along_02 = dist2(p0, p2) <= dist2(p1, p3);
        }
        uint o = 6u * quad;
        if (along_02) {
            indices[o] = v[0];
            indices[o + 1u] = v[1];
            indices[o + 2u] = v[2];
            indices[o + 3u] = v[0];
            indices[o + 4u] = v[2];
            indices[o + 5u] = v[3];
        } else {
            indices[o] = v[0];
            indices[o + 1u] = v[1];
            indices[o + 2u] = v[3];
            indices[o + 3u] = v[1];
            indices[o + 4u] = v[2];
            indices[o + 5u] = v[3];
        }
        return;
    }
}
