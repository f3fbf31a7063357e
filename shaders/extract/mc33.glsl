// MC33 per cell (`src/mesh/mc33.rs`, whose module docs state the rules): face segments by the
// asymptotic decider, contours, interior connections by the exact z sweep, pieces, and their
// triangles (disk fans; tunnel strips chosen by the same dynamic programme). Every decision
// is taken in f64 with the reference's operations in the reference's order (`precise`: no
// fused multiply-adds), so on IEEE f64 hardware (lavapipe: x86 SSE2) the GPU takes the same
// decision as the CPU even at near ties. Included after common.glsl by `mc33_count.comp` and
// `mc33_emit.comp`; one invocation handles one cell in private (per-invocation) globals.

// The 6 faces, corners counter-clockwise about the outward normal (`mc33::FACES`).
const int FACES[24] = int[24](0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5);

// Vertex codes of a cell's triangles (`mc33::Vert`): 0..11 the crossed edge (Bourke number);
// CENTRE + e0 the centre of the contour starting at edge e0; MID + 12 a + b (a < b) the vertex
// near the midpoint of the rung between edges a and b.
const int CENTRE = 16;
const int MID = 32;

double ISO;        // the isovalue in f64
ivec3 CELL;        // the cell (pad is 0 for mc33: padded = grid coordinates)
double V[8];       // corner samples
double G[8];       // inside-positive corner values: inside iff > 0
// Union-find over the corners (0..7) and the sweep's (sample s, section corner q) nodes
// (8 + 4 s + q, at most 9 samples): the connected regions of inside and outside.
int UF[44];
int NEXT[12];      // the edge after each crossed edge along its contour
int EF[12];        // faces containing each edge (bit = index in FACES)
int CE[12];        // contours' edges, concatenated
int CSTART[5];     // contour c is CE[CSTART[c] .. CSTART[c + 1])
int NCONT;
dvec3 POS[12];     // index-space crossing point of each crossed edge
dvec3 DIR[12];     // its inside -> outside direction
int PA[4];         // pieces: first contour, and second (-1 for a disk)
int PB[4];
int NPIECE;
double COST[784];  // tunnel DP over (n + 1)(m + 1) rungs x 4 x 4 spreads, n + m <= 12
uint BACK[784];
int BEST[36];      // the best tunnel walk's triangles (edge numbers)

// Output state: counting only, or writing triangles and added vertices.
bool WRITE;
uint NTRI;         // triangles so far
uint TRI_OUT;      // slab index of the cell's first triangle
int ADDED[16];     // codes of the added vertices so far, in order of first use
int NADDED;
uint ADDED_ID;     // global number of the cell's first added vertex
uint ADDED_OUT;    // slab output index of the cell's first added vertex
int CUR_CONTOUR;   // the contour of the disk being emitted (for its centre)

double iso64() {
    return packDouble2x32(P.iso_bits.xy);
}

int edge_of(int a, int b) {
    return mc_edge_index[8 * a + b];
}

// (No path halving: the trees are tiny, and lavapipe's compiler lost unions made after a
// halving `UF[x] = UF[UF[x]]` in this shader.)
int find(int x) {
    while (UF[x] != x) {
        x = UF[x];
    }
    return x;
}

void unite(int a, int b) {
    int ra = find(a);
    int rb = find(b);
    UF[max(ra, rb)] = min(ra, rb);
}

bool share_face(int a, int b) {
    return (EF[a] & EF[b]) != 0;
}

// `mc33::cell_pieces` step 1: face segments (asymptotic decider) and boundary connections.
void face_segments() {
    for (int e = 0; e < 12; e++) {
        NEXT[e] = -1;
        EF[e] = 0;
    }
    for (int f = 0; f < 6; f++) {
        int c[4];
        bool ins[4];
        int ed[4];
        int n_in = 0;
        for (int k = 0; k < 4; k++) {
            c[k] = FACES[4 * f + k];
            ins[k] = G[c[k]] > 0.0;
            n_in += int(ins[k]);
        }
        for (int k = 0; k < 4; k++) {
            ed[k] = edge_of(c[k], c[(k + 1) & 3]);
            EF[ed[k]] |= 1 << f;
        }
        bool ambiguous = n_in == 2 && ins[0] == ins[2];
        for (int k = 0; k < 4; k++) {
            if (ins[k] == ins[(k + 1) & 3]) {
                unite(c[k], c[(k + 1) & 3]);
            }
        }
        if (ambiguous) {
            int a = ins[0] ? 0 : 1;
            int b = 1 - a;
            precise double saddle = G[c[a]] * G[c[a + 2]] - G[c[b]] * G[c[b + 2]];
            bool join_inside = saddle > 0.0;
            if (join_inside) {
                unite(c[a], c[a + 2]);
            } else {
                unite(c[b], c[b + 2]);
            }
            for (int k = 0; k < 4; k++) {
                if (join_inside && !ins[k]) {
                    NEXT[ed[k]] = ed[(k + 3) & 3];
                } else if (!join_inside && ins[k]) {
                    NEXT[ed[(k + 3) & 3]] = ed[k];
                }
            }
        } else if (n_in != 0 && n_in != 4) {
            int entering = -1;
            int leaving = -1;
            for (int k = 0; k < 4; k++) {
                if (entering < 0 && !ins[k] && ins[(k + 1) & 3]) {
                    entering = k;
                }
                if (leaving < 0 && ins[k] && !ins[(k + 1) & 3]) {
                    leaving = k;
                }
            }
            if (entering >= 0 && leaving >= 0) {
                NEXT[ed[entering]] = ed[leaving];
            }
        }
    }
}

// Step 2: contours, traced from the lowest unvisited edge.
void trace_contours() {
    bool seen[12];
    for (int e = 0; e < 12; e++) {
        seen[e] = false;
    }
    NCONT = 0;
    int n = 0;
    for (int start = 0; start < 12; start++) {
        if (NEXT[start] < 0 || seen[start] || NCONT == 4) {
            continue;
        }
        CSTART[NCONT] = n;
        int e = start;
        while (e >= 0 && !seen[e]) {
            seen[e] = true;
            CE[n++] = e;
            e = NEXT[e];
        }
        NCONT++;
    }
    CSTART[NCONT] = n;
}

// Step 3: corners connected through the interior (`mc33::sweep`).
void sweep() {
    double a[4];
    double b[4];
    for (int q = 0; q < 4; q++) {
        a[q] = G[q];
        b[q] = G[q + 4] - G[q];
    }
    double ev[6];
    int ne = 0;
    for (int q = 0; q < 4; q++) {
        if (b[q] != 0.0) {
            ev[ne++] = -a[q] / b[q];
        }
    }
    precise double qa = b[0] * b[3] - b[1] * b[2];
    precise double qb = a[0] * b[3] + a[3] * b[0] - a[1] * b[2] - a[2] * b[1];
    precise double qc = a[0] * a[3] - a[1] * a[2];
    if (qa != 0.0) {
        precise double disc = qb * qb - 4.0 * qa * qc;
        if (disc >= 0.0) {
            double r = sqrt(disc);
            ev[ne++] = (-qb - r) / (2.0 * qa);
            ev[ne++] = (-qb + r) / (2.0 * qa);
        }
    } else if (qb != 0.0) {
        ev[ne++] = -qc / qb;
    }
    // Keep the events in (0, 1), sorted, without repeats.
    int m = 0;
    for (int i = 0; i < ne; i++) {
        if (ev[i] > 0.0 && ev[i] < 1.0) {
            ev[m++] = ev[i];
        }
    }
    for (int i = 1; i < m; i++) {
        double x = ev[i];
        int j = i - 1;
        while (j >= 0 && ev[j] > x) {
            ev[j + 1] = ev[j];
            j--;
        }
        ev[j + 1] = x;
    }
    double samples[9];
    int ns = 0;
    samples[ns++] = 0.0;
    double prev = 0.0;
    for (int i = 0; i < m; i++) {
        if (i > 0 && ev[i] == ev[i - 1]) {
            continue;
        }
        samples[ns++] = 0.5 * (prev + ev[i]);
        prev = ev[i];
    }
    samples[ns++] = 0.5 * (prev + 1.0);
    samples[ns++] = 1.0;

    for (int i = 8; i < 8 + 4 * ns; i++) {
        UF[i] = i;
    }
    bool prev_in[4] = bool[4](false, false, false, false);
    for (int s = 0; s < ns; s++) {
        double t = samples[s];
        double gt[4];
        bool ins[4];
        for (int q = 0; q < 4; q++) {
            precise double v = a[q] + t * b[q];
            gt[q] = v;
            ins[q] = v > 0.0;
        }
        const ivec2 SQUARE[4] = ivec2[4](ivec2(0, 1), ivec2(1, 3), ivec2(3, 2), ivec2(2, 0));
        for (int k = 0; k < 4; k++) {
            if (ins[SQUARE[k].x] == ins[SQUARE[k].y]) {
                unite(8 + 4 * s + SQUARE[k].x, 8 + 4 * s + SQUARE[k].y);
            }
        }
        if (ins[0] == ins[3] && ins[1] == ins[2] && ins[0] != ins[1]) {
            precise double s03 = gt[0] * gt[3] - gt[1] * gt[2];
            bool join_03 = ins[0] ? s03 > 0.0 : s03 >= 0.0;
            if (join_03) {
                unite(8 + 4 * s, 8 + 4 * s + 3);
            } else {
                unite(8 + 4 * s + 1, 8 + 4 * s + 2);
            }
        }
        if (s > 0) {
            for (int q = 0; q < 4; q++) {
                if (ins[q] == prev_in[q]) {
                    unite(8 + 4 * (s - 1) + q, 8 + 4 * s + q);
                }
            }
        }
        prev_in = ins;
    }
    // Each corner is its node in the first or last section: corners joined through the
    // interior end up in one region (`mc33::sweep` unites them pairwise; same partition).
    int last = ns - 1;
    for (int c = 0; c < 8; c++) {
        unite(c, 8 + ((c & 4) == 0 ? 0 : 4 * last) + (c & 3));
    }
}

// Step 4: contours grouped by (inside region, outside region) into pieces, in order of their
// first contour; a group of more than two (a degenerate tie) becomes one disk per contour.
void group_pieces() {
    int key[4];
    for (int c = 0; c < NCONT; c++) {
        int e = CE[CSTART[c]];
        int a = mc_edges[2 * e];
        int b = a | (1 << mc_edges[2 * e + 1]);
        int ci = G[a] > 0.0 ? a : b;
        int co = ci == a ? b : a;
        key[c] = find(ci) * 8 + find(co);
    }
    NPIECE = 0;
    for (int c = 0; c < NCONT; c++) {
        bool first = true;
        for (int d = 0; d < c; d++) {
            first = first && key[d] != key[c];
        }
        if (!first) {
            continue;
        }
        int others = 0;
        int other = -1;
        for (int d = c + 1; d < NCONT; d++) {
            if (key[d] == key[c]) {
                others++;
                other = other < 0 ? d : other;
            }
        }
        if (others <= 1) {
            PA[NPIECE] = c;
            PB[NPIECE] = other;
            NPIECE++;
        } else {
            PA[NPIECE] = c;
            PB[NPIECE] = -1;
            NPIECE++;
            for (int d = c + 1; d < NCONT; d++) {
                if (key[d] == key[c]) {
                    PA[NPIECE] = d;
                    PB[NPIECE] = -1;
                    NPIECE++;
                }
            }
        }
    }
}

// Crossing parameter in f64 (`mesh::field::crossing`).
double crossing64(double a, double b) {
    double s = (ISO - a) / (b - a);
    return isnan(s) ? 0.5 : clamp(s, 0.0, 1.0);
}

// POS and DIR of the crossed edges.
void edge_points() {
    for (int k = 0; k < CSTART[NCONT]; k++) {
        int e = CE[k];
        int c = mc_edges[2 * e];
        int axis = mc_edges[2 * e + 1];
        int end = c | (1 << axis);
        double s = crossing64(V[c], V[end]);
        ivec3 o = offset_of(uint(c));
        dvec3 u = dvec3(CELL) + dvec3(o);
        u[axis] += s;
        dvec3 d = dvec3(0.0);
        d[axis] = G[c] > 0.0 ? 1.0 : -1.0;
        POS[e] = u;
        DIR[e] = d;
    }
}

// Writes added vertex `i` (code `code`) at its output slot.
void write_added(int i, int code) {
    dvec3 u;
    dvec3 dir;
    if (code < MID) {
        int c = CUR_CONTOUR;
        dvec3 su = dvec3(0.0);
        dvec3 sd = dvec3(0.0);
        for (int k = CSTART[c]; k < CSTART[c + 1]; k++) {
            su += POS[CE[k]];
            sd += DIR[CE[k]];
        }
        u = su / double(CSTART[c + 1] - CSTART[c]);
        dir = sd;
    } else {
        int a = (code - MID) / 12;
        int b = (code - MID) % 12;
        dvec3 mid = 0.5 * (POS[a] + POS[b]);
        u = mid + 0.25 * (dvec3(CELL) + dvec3(0.5) - mid);
        dir = DIR[a] + DIR[b];
    }
    vec3 local = vec3(u - dvec3(CELL));
    uint slot = ADDED_OUT + uint(i);
    positions[slot] = vec4(world(CELL, local), 1.0);
    normals[slot] = vec4(normal_at(CELL, local, vec3(dir)), 0.0);
}

// The vertex id of a code (added vertices: the placeholder u32::MAX - global added number,
// which `mc33_fixup.comp` turns into the final id once all edge vertices are counted).
uint vertex_id(int code) {
    if (code < 12) {
        if (!WRITE) {
            return 0u;
        }
        int c = mc_edges[2 * code];
        return edge_vertex(CELL + offset_of(uint(c)), uint(mc_edges[2 * code + 1]));
    }
    for (int i = 0; i < NADDED; i++) {
        if (ADDED[i] == code) {
            return 0xFFFFFFFFu - (ADDED_ID + uint(i));
        }
    }
    int i = min(NADDED, 15);
    ADDED[i] = code;
    NADDED = i + 1;
    if (WRITE) {
        write_added(i, code);
    }
    return 0xFFFFFFFFu - (ADDED_ID + uint(i));
}

void emit_tri(int x, int y, int z) {
    uint a = vertex_id(x);
    uint b = vertex_id(y);
    uint c = vertex_id(z);
    if (WRITE) {
        uint t = 3u * (TRI_OUT + NTRI);
        indices[t] = a;
        indices[t + 1u] = b;
        indices[t + 2u] = c;
    }
    NTRI++;
}

// `mc33::disk`.
void disk(int contour) {
    int base = CSTART[contour];
    int n = CSTART[contour + 1] - base;
    int apex = -1;
    for (int a = 0; a < n && apex < 0; a++) {
        bool ok = true;
        for (int w = 0; w < n; w++) {
            int d = (w + n - a) % n;
            ok = ok && (d <= 1 || d == n - 1 || !share_face(CE[base + a], CE[base + w]));
        }
        if (ok) {
            apex = a;
        }
    }
    if (apex >= 0) {
        for (int k = 1; k < n - 1; k++) {
            emit_tri(CE[base + apex], CE[base + (apex + k) % n], CE[base + (apex + k + 1) % n]);
        }
    } else {
        CUR_CONTOUR = contour;
        for (int w = 0; w < n; w++) {
            emit_tri(CENTRE + CE[base], CE[base + w], CE[base + (w + 1) % n]);
        }
    }
}

// Rung cost of `mc33::tube`: squared length, plus 1000 if the rung must be split.
double rung(int x, int y) {
    double split = share_face(x, y) ? 1000.0 : 0.0;
    dvec3 d = POS[x] - POS[y];
    precise double dd = d.x * d.x + d.y * d.y + d.z * d.z;
    precise double c = split + dd;
    return c;
}

int moved(int s) {
    return s <= 1 ? 1 : 3;
}
int waited(int s) {
    return s == 1 ? 2 : s;
}

// `mc33::tube`: the cheapest closed strip between contours pc and qc, rungs on a common face
// split by an added vertex.
void tube(int pc, int qc) {
    int pb = CSTART[pc];
    int n = CSTART[pc + 1] - pb;
    int qb = CSTART[qc];
    int m = CSTART[qc + 1] - qb;
    double INF = packDouble2x32(uvec2(0u, 0x7FF00000u));
    double best = INF;
    bool have_best = false;
    int best_len = 0;
    for (int j0 = 0; j0 < m; j0++) {
        int size = (n + 1) * (m + 1) * 16;
        for (int k = 0; k < size; k++) {
            COST[k] = INF;
            BACK[k] = 0u;
        }
        // pv(i) = CE[pb + i % n]; qv(j) = reversed q from j0: CE[qb + m - 1 - (j0 + j) % m].
        COST[0] = rung(CE[pb], CE[qb + m - 1 - j0 % m]);
        for (int i = 0; i <= n; i++) {
            for (int j = 0; j <= m; j++) {
                for (int a = 0; a < 4; a++) {
                    for (int b = 0; b < 4; b++) {
                        int k = ((i * (m + 1) + j) * 4 + a) * 4 + b;
                        double c = COST[k];
                        if (isinf(c)) {
                            continue;
                        }
                        if (i < n) {
                            double h = (i + 1 == n && j == m)
                                ? 0.0
                                : rung(CE[pb + (i + 1) % n], CE[qb + m - 1 - (j0 + j) % m]);
                            int t = (((i + 1) * (m + 1) + j) * 4 + moved(a)) * 4 + waited(b);
                            precise double nc = c + h;
                            if (nc < COST[t]) {
                                COST[t] = nc;
                                BACK[t] = 1u | (uint(a) << 1) | (uint(b) << 3);
                            }
                        }
                        if (j < m) {
                            double h = (i == n && j + 1 == m)
                                ? 0.0
                                : rung(CE[pb + i % n], CE[qb + m - 1 - (j0 + j + 1) % m]);
                            int t = ((i * (m + 1) + j + 1) * 4 + waited(a)) * 4 + moved(b);
                            precise double nc = c + h;
                            if (nc < COST[t]) {
                                COST[t] = nc;
                                BACK[t] = (uint(a) << 1) | (uint(b) << 3);
                            }
                        }
                    }
                }
            }
        }
        double total = COST[((n * (m + 1) + m) * 4 + 3) * 4 + 3];
        if (isinf(total) || (have_best && best <= total)) {
            continue;
        }
        // Walk back from (n, m), filling BEST from its end.
        int i = n;
        int j = m;
        int a = 3;
        int b = 3;
        int k = n + m;
        while (i != 0 || j != 0) {
            uint bk = BACK[((i * (m + 1) + j) * 4 + a) * 4 + b];
            k--;
            int pi = CE[pb + i % n];
            int qj = CE[qb + m - 1 - (j0 + j) % m];
            if ((bk & 1u) != 0u) {
                BEST[3 * k] = CE[pb + (i - 1) % n];
                BEST[3 * k + 1] = pi;
                BEST[3 * k + 2] = qj;
                i--;
            } else {
                BEST[3 * k] = pi;
                BEST[3 * k + 1] = qj;
                BEST[3 * k + 2] = CE[qb + m - 1 - (j0 + j - 1) % m];
                j--;
            }
            a = int((bk >> 1) & 3u);
            b = int((bk >> 3) & 3u);
        }
        best = total;
        have_best = true;
        best_len = n + m;
    }
    // Split the rungs on a common face: fan each triangle touching one around its vertex.
    for (int t = 0; t < best_len; t++) {
        int poly[5];
        int np = 0;
        int last_mid = -1;
        for (int k = 0; k < 3; k++) {
            int x = BEST[3 * t + k];
            int y = BEST[3 * t + (k + 1) % 3];
            poly[np++] = x;
            bool x_in_p = false;
            bool y_in_p = false;
            for (int r = 0; r < n; r++) {
                x_in_p = x_in_p || CE[pb + r] == x;
                y_in_p = y_in_p || CE[pb + r] == y;
            }
            if (x_in_p != y_in_p && share_face(x, y)) {
                last_mid = np;
                poly[np++] = MID + 12 * min(x, y) + max(x, y);
            }
        }
        if (last_mid < 0) {
            emit_tri(poly[0], poly[1], poly[2]);
        } else {
            for (int k = 1; k < np - 1; k++) {
                emit_tri(poly[last_mid], poly[(last_mid + k) % np], poly[(last_mid + k + 1) % np]);
            }
        }
    }
}

// Builds cell c's surface: counts its triangles (NTRI) and added vertices (NADDED), and with
// WRITE set writes them. The cell must have inside and outside corners.
void cell_mesh(ivec3 c) {
    CELL = c;
    ISO = iso64();
    double sign = P.iso.w > 0.0 ? -1.0 : 1.0;
    for (int n = 0; n < 8; n++) {
        V[n] = double(value_at(c + offset_of(uint(n))));
        G[n] = sign * (V[n] - ISO);
        UF[n] = n;
    }
    NTRI = 0u;
    NADDED = 0;
    face_segments();
    trace_contours();
    if (NCONT > 1) {
        sweep();
        group_pieces();
    } else {
        // One contour is one disk whatever the regions (the sweep only groups contours).
        NPIECE = 1;
        PA[0] = 0;
        PB[0] = -1;
    }
    edge_points();
    for (int p = 0; p < NPIECE; p++) {
        if (PB[p] < 0) {
            disk(PA[p]);
        } else {
            tube(PA[p], PB[p]);
        }
    }
}
