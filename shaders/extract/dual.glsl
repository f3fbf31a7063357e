// The vertex of a padded cell for the dual methods (`mesh/dual.rs`), shared by the vertex pass
// and, for the shorter-diagonal quad split, the quad pass. Needs common.glsl and the masks of
// the cell's 8 corner points in the slab's point buffers.

struct CellVertex {
    vec3 local;      // mean of the crossing points, relative to grid point c - pad
    vec3 fallback;   // inside -> outside directions of the crossed edges, summed (index space)
};

// Mean of the crossing points of padded cell c's crossed edges, summed in the CPU's order: x
// edges, y edges, z edges, and within axis a by the offsets along (a + 1, a + 2) mod 3:
// (0,0), (1,0), (0,1), (1,1). False if no edge is crossed.
bool cell_vertex(ivec3 c, out CellVertex cv) {
    precise vec3 sum = vec3(0.0);
    vec3 dir = vec3(0.0);
    uint n = 0u;
    for (int a = 0; a < 3; a++) {
        ivec3 ea = ivec3(0);
        ea[a] = 1;
        ivec3 eb = ivec3(0);
        eb[(a + 1) % 3] = 1;
        ivec3 ec = ivec3(0);
        ec[(a + 2) % 3] = 1;
        for (int m = 0; m < 4; m++) {
            ivec3 q = c + (m & 1) * eb + (m >> 1) * ec;
            uint mask = point_mask[point_slot(q)];
            if ((mask & (1u << a)) == 0u) {
                continue;
            }
            vec3 u = vec3(q - c);
            u[a] += padded_crossing(q, ea);
            sum += u;
            dir += (mask & INSIDE_BIT) != 0u ? vec3(ea) : -vec3(ea);
            n++;
        }
    }
    precise vec3 local = sum / float(max(n, 1u));
    cv.local = local;
    cv.fallback = dir;
    return n > 0u;
}

// World position of a cell vertex.
vec3 cell_vertex_world(ivec3 c, CellVertex cv) {
    return world(c - pad(), cv.local);
}
