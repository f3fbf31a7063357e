// The vertex of a padded cell for the dual methods (`mesh/dual.rs`), shared by the vertex pass
// and, for the shorter-diagonal quad split, the quad pass. Needs common.glsl and the masks of
// the cell's 8 corner points in the slab's point buffers.

struct CellVertex {
    vec3 local;      // mean of the crossing points, relative to grid point c - pad
    vec3 fallback;   // inside -> outside directions of the crossed edges, summed (index space)
};

// dual-contouring-qef (`mesh/qef.rs`, `mesh/dcqef.rs`) in f32: P.iso_bits.z bit 0 turns it
// on, bit 1 clamps into the cell, P.iso_bits.w holds the singular-value threshold's bits.
bool qef_on() {
    return (P.iso_bits.z & 1u) != 0u;
}

// Eigenvalues (returned) and unit eigenvectors (columns of v) of the symmetric a by cyclic
// Jacobi, the CPU's `eigen_symmetric` (a[col][row]).
vec3 eigen_symmetric(mat3 a, out mat3 v) {
    v = mat3(1.0);
    for (int sweep = 0; sweep < 16; sweep++) {
        float off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        float diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if (off <= 1e-14 * diag || off == 0.0) {
            break;
        }
        for (int r = 0; r < 3; r++) {
            int p = r == 2 ? 1 : 0;
            int q = r == 0 ? 1 : 2;
            float apq = a[p][q];
            if (apq == 0.0) {
                continue;
            }
            float tau = (a[q][q] - a[p][p]) / (2.0 * apq);
            float t = tau == 0.0 ? 1.0 : sign(tau) / (abs(tau) + sqrt(1.0 + tau * tau));
            float co = 1.0 / sqrt(1.0 + t * t);
            float si = t * co;
            for (int k = 0; k < 3; k++) {
                float mkp = a[k][p], mkq = a[k][q];
                a[k][p] = co * mkp - si * mkq;
                a[k][q] = si * mkp + co * mkq;
            }
            vec3 mp = a[p], mq = a[q];
            a[p] = co * mp - si * mq;
            a[q] = si * mp + co * mq;
            vec3 vp = v[p], vq = v[q];
            v[p] = co * vp - si * vq;
            v[q] = si * vp + co * vq;
        }
    }
    return vec3(a[0][0], a[1][1], a[2][2]);
}

// The QEF minimiser (`Qef::solve`), cell-local coordinates: pseudo-inverse about the mass
// point m with singular values below the threshold dropped; kept in [0, 1]³ when clamping, an
// edge's vertex sliding along the edge.
vec3 qef_solve(mat3 ata, vec3 atb, vec3 m) {
    float threshold = uintBitsToFloat(P.iso_bits.w);
    vec3 rhs = atb - ata * m;
    mat3 vecs;
    vec3 vals = eigen_symmetric(ata, vecs);
    float mx = max(max(max(vals.x, vals.y), vals.z), 0.0);
    float cut = threshold * threshold * mx;
    vec3 y = vec3(0.0);
    vec3 free_dir = vec3(0.0);
    int nfree = 0;
    for (int i = 0; i < 3; i++) {
        vec3 v = vecs[i];
        if (mx > 0.0 && vals[i] > cut) {
            y += v * (dot(v, rhs) / vals[i]);
        } else {
            free_dir = v;
            nfree++;
        }
    }
    vec3 x = m + y;
    bool in_cell = all(greaterThanEqual(x, vec3(0.0))) && all(lessThanEqual(x, vec3(1.0)));
    if ((P.iso_bits.z & 2u) == 0u || in_cell) {
        return x;
    }
    if (nfree == 1) {
        float inf = uintBitsToFloat(0x7f800000u);
        float t0 = -inf, t1 = inf;
        for (int a = 0; a < 3; a++) {
            if (abs(free_dir[a]) > 1e-12) {
                float p = (0.0 - x[a]) / free_dir[a], q = (1.0 - x[a]) / free_dir[a];
                t0 = max(t0, min(p, q));
                t1 = min(t1, max(p, q));
            } else if (x[a] < 0.0 || x[a] > 1.0) {
                t0 = inf;
            }
        }
        if (t0 <= t1) {
            return clamp(x + free_dir * clamp(0.0, t0, t1), vec3(0.0), vec3(1.0));
        }
    }
    return clamp(x, vec3(0.0), vec3(1.0));
}

// Mean of the crossing points of padded cell c's crossed edges, summed in the CPU's order: x
// edges, y edges, z edges, and within axis a by the offsets along (a + 1, a + 2) mod 3:
// (0,0), (1,0), (0,1), (1,1); for dual-contouring-qef, on a cell of the grid, the QEF
// minimiser of the crossings' tangent planes (trilinear Hermite data) instead. False if no
// edge is crossed.
bool cell_vertex(ivec3 c, out CellVertex cv) {
    precise vec3 sum = vec3(0.0);
    vec3 dir = vec3(0.0);
    uint n = 0u;
    ivec3 g = c - pad();
    bool qef = qef_on() && all(greaterThanEqual(g, ivec3(0))) && all(lessThan(g, P.dims.xyz - 1));
    mat3 ata = mat3(0.0);
    vec3 atb = vec3(0.0);
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
            if (qef) {
                vec3 nrm;
                if (!unit(gradient_at(g, u), nrm)) {
                    nrm = vec3(0.0);
                }
                ata += outerProduct(nrm, nrm);
                atb += nrm * dot(nrm, u);
            }
        }
    }
    precise vec3 local = sum / float(max(n, 1u));
    if (qef && n > 0u) {
        local = qef_solve(ata, atb, local);
    }
    cv.local = local;
    cv.fallback = dir;
    return n > 0u;
}

// World position of a cell vertex.
vec3 cell_vertex_world(ivec3 c, CellVertex cv) {
    return world(c - pad(), cv.local);
}
