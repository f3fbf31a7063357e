#version 450
// Extraction pass `points`: classify the padded lattice points of a slab.
//
// One invocation per point of the slab's point layers. Writes the point's mask (inside bit and
// one bit per crossed edge family starting at it) and the count of what the point owns, which
// the scan turns into ids:
//   mode 0 (marching cubes): families x, y, z; count = crossed edges = vertices
//   mode 1 (marching tetrahedra): the 7 families of MT_FAMILIES; count = vertices
//   mode 2 (dual methods): families x, y, z on the padded lattice; count = quads, i.e. crossed
//          edges with four cells around them

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = 64) in;

#include "common.glsl"

const uint MODE_MC = 0u;
const uint MODE_MT = 1u;
const uint MODE_DUAL = 2u;

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    ivec3 n = np();
    ivec3 q = item_coords(id, n.xy);
    bool in_q = padded_inside(q);
    uint mask = in_q ? INSIDE_BIT : 0u;
    uint families = C.mode == MODE_MT ? 7u : 3u;
    for (uint f = 0u; f < families; f++) {
        uint bits = C.mode == MODE_MT ? f + 1u : 1u << f;
        ivec3 r = q + offset_of(bits);
        if (any(greaterThanEqual(r, n))) {
            continue;
        }
        if (padded_inside(r) != in_q) {
            mask |= 1u << f;
        }
    }
    uint count;
    if (C.mode == MODE_DUAL) {
        // A quad needs the four cells around the edge: both other coordinates in 1 .. nc - 1.
        ivec3 cells = nc();
        count = 0u;
        for (int a = 0; a < 3; a++) {
            int b = (a + 1) % 3;
            int c = (a + 2) % 3;
            if ((mask & (1u << a)) != 0u && q[b] >= 1 && q[c] >= 1 && q[b] < cells[b]
                && q[c] < cells[c]) {
                count++;
            }
        }
    } else {
        count = bitCount(mask & EDGE_BITS);
    }
    uint slot = point_slot(q);
    point_mask[slot] = mask;
    point_scan[slot] = count;
}
