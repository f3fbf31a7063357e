#version 450
// Extraction pass `classify`: classify the padded lattice points and cells of a slab.
//
// One invocation per point of the slab's point layers. Writes the point's mask (inside bit and
// one bit per crossed edge family starting at it) and the count of what the point owns, and,
// where the point is corner 0 of a cell of the slab's cell layers, the count of what that cell
// owns; the scans turn the counts into ids:
//   mode 0 (marching cubes): families x, y, z; point: crossed edges = vertices; cell: triangles
//   mode 1 (marching tetrahedra): the 7 families of MT_FAMILIES; point: vertices; cell:
//          triangles
//   mode 2 (dual methods): families x, y, z on the padded lattice; point: quads, i.e. crossed
//          edges with four cells around them; cell: 1 if active (a corner differs), its vertex
//   mode 3 (mc33): families x, y, z; point: vertices; cell: 1 if crossed, so the scan numbers
//          the crossed cells and the mc33 passes run over them only

// Before the include: common.glsl reads gl_WorkGroupSize.
layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

#include "common.glsl"

// MODE_MC, MODE_MT, MODE_DUAL, MODE_MC33: #defines from build.rs (`classify_mode` in Rust).

// What the cell with inside-corner mask `mask` (bit n for corner n) owns.
uint cell_count(uint mask) {
    if (mask == 0u || mask == 255u) {
        return 0u;
    }
    if (C.mode == MODE_DUAL || C.mode == MODE_MC33) {
        return 1u;
    }
    if (C.mode == MODE_MC) {
        int row = 0;
        for (int b = 0; b < 8; b++) {
            row |= int((mask >> uint(mc_vertex_corner[b])) & 1u) << b;
        }
        row *= 16;
        uint n = 0u;
        while (n < 15u && mc_triangles[row + int(n)] >= 0) {
            n += 3u;
        }
        return n / 3u;
    }
    uint t = 0u;
    for (int tet = 0; tet < 6; tet++) {
        int tcase = 0;
        for (int l = 0; l < 4; l++) {
            tcase |= int((mask >> uint(mt_tets[4 * tet + l])) & 1u) << l;
        }
        int row = tcase * 6;
        for (int n = 0; n < 6 && mt_triangles[row + n] >= 0; n += 3) {
            t++;
        }
    }
    return t;
}

// Whether one of the four cells around the edge from padded point q along axis a (offsets -1
// and 0 along the other two axes) is missing: a point of theirs, besides the edge's own finite
// ends, is missing data.
bool ring_missing(ivec3 q, int a) {
    int b = (a + 1) % 3;
    int c = (a + 2) % 3;
    for (int i = 0; i < 2; i++) {
        for (int j = -1; j <= 1; j++) {
            for (int k = -1; k <= 1; k++) {
                ivec3 r = q;
                r[a] += i;
                r[b] += j;
                r[c] += k;
                if (padded_missing(r)) return true;
            }
        }
    }
    return false;
}

void main() {
    uint id = item_index();
    if (id >= C.count) {
        return;
    }
    ivec3 n = np();
    ivec3 q = item_coords(id, n.xy);
    // Inside bits of the 8 points q + offset(k) (0 beyond the lattice): each sample is read
    // once here, for the point's edges and for its cell alike.
    uint corners = 0u;
    uint missing = 0u;  // bit k: point q + offset(k) is missing data (missing.glsl)
    for (uint k = 0u; k < 8u; k++) {
        ivec3 r = q + offset_of(k);
        if (all(lessThan(r, n))) {
            if (padded_inside(r)) corners |= 1u << k;
            if (padded_missing(r)) missing |= 1u << k;
        }
    }
    bool in_q = (corners & 1u) != 0u;
    uint mask = in_q ? INSIDE_BIT : 0u;
    uint families = C.mode == MODE_MT ? 7u : 3u;
    for (uint f = 0u; f < families; f++) {
        uint bits = C.mode == MODE_MT ? f + 1u : 1u << f;
        // An edge with a missing end is not crossed (no finite cell holds it).
        if (all(lessThan(q + offset_of(bits), n)) && ((corners >> bits) & 1u) != uint(in_q)
            && ((missing | (missing >> bits)) & 1u) == 0u) {
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
                if (ring_missing(q, a)) {
                    mask |= RING_MISSING << a;  // a missing cell around it: no quad
                } else {
                    count++;
                }
            }
        }
    } else {
        count = bitCount(mask & EDGE_BITS);
    }
    uint slot = point_slot(q);
    point_mask[slot] = mask;
    point_scan[slot] = count;
    ivec3 cells = nc();
    if (q.x < cells.x && q.y < cells.y && q.z >= C.cell_z0) {
        uint cslot = cell_slot(q);
        if (cslot < C.owned_cell_end) {
            // A missing cell owns nothing (`cell_missing`).
            cell_scan[cslot] = missing != 0u ? 0u : cell_count(corners);
        }
    }
}
