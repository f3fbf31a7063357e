// Shared by the extraction passes (`src/passes/extract.rs`): the resources every pass binds,
// the slab push constants, the padded lattice, the inside rule, crossing points and normals.
// Mirrors `src/mesh/field.rs` (f64) in f32; see the module docs of `mesh` for the rules.
//
// Lattice: grid point (i, j, k) is *padded* point q = (i, j, k) + pad, where pad is 1 for dual
// contouring (a layer of points outside the box that count as outside) and 0 otherwise. Padded
// cell c spans padded points c .. c + 1. Items of a dispatch are points or cells of consecutive
// z layers starting at layer C.z0, numbered x fastest (the emit passes instead take one
// invocation per output item); the slab's point and cell buffers hold consecutive layers
// starting at C.point_z0 and C.cell_z0, and its copy of the samples (gathered from the grid
// image once by the `values` pass, so the other passes read a plain buffer) the padded point
// layers from C.value_z0.

#include "missing.glsl"
#include "interpolant.glsl"

layout(std140, binding = 0) uniform Params {
    ivec4 dims;     // xyz: grid points per axis; w: padding layers (pad)
    vec4 box_min;   // xyz: world position of grid point (0, 0, 0)
    vec4 spacing;   // xyz: world size of one cell
    vec4 iso;       // x: inside threshold; y + z: the isovalue as f32 hi + lo; w: +1 below, -1 above
    uvec4 iso_bits; // xy: the f64 isovalue's bits, low word first (read by the mc33 passes)
} P;

layout(binding = 1) uniform sampler3D u_grid;

// Per point of the slab: bit f set iff the edge of family f from the point is crossed; bit 8
// set iff the point is inside.
layout(std430, binding = 2) buffer PointMasks { uint point_mask[]; };
// Per point: the count of what it owns (MC/MT vertices, dual quads), scanned in place into
// exclusive prefix sums (one extra element holds the total).
layout(std430, binding = 3) buffer PointScan { uint point_scan[]; };
// Per cell: MC/MT triangles, dual vertices, 1 for a crossed MC33 cell; scanned likewise.
layout(std430, binding = 4) buffer CellScan { uint cell_scan[]; };
// MC33, per crossed cell (numbered by cell_scan): its triangles and its added vertices; scanned
// likewise. (Dummies for the other algorithms.)
layout(std430, binding = 10) buffer AddedScan { uint added_scan[]; };
layout(std430, binding = 11) buffer TriScan { uint tri_scan[]; };

// `mesh::tables`, uploaded as the Rust struct `ExtractTables` (std430 int arrays).
layout(std430, binding = 5) readonly buffer Tables {
    int mc_triangles[256 * 16];
    int mc_edges[12 * 2];
    int mc_vertex_corner[8];
    int mt_tets[6 * 4];
    int mt_tet_edges[6 * 2];
    int mt_triangles[16 * 6];
    int mc_edge_index[8 * 8];  // Bourke edge between corners a and b at 8 a + b, else -1
};

// The slab's output: vertices (xyz, w = 1), normals (xyz, w = 0), triangles (3 global vertex
// ids each), all indexed from the slab's first vertex / triangle. (The dual quad pass reads
// the positions back for the shorter-diagonal split; the mc33 fixup rewrites indices.)
layout(std430, binding = 6) buffer Positions { vec4 positions[]; };
layout(std430, binding = 7) writeonly buffer Normals { vec4 normals[]; };
layout(std430, binding = 8) buffer Indices { uint indices[]; };

// The samples of the slab's padded point layers from C.value_z0 (0 at padding points).
layout(std430, binding = 9) buffer Values { float values[]; };

// `SlabPush` in Rust.
layout(push_constant) uniform Push {
    uint groups_x;     // workgroups along x of this dispatch (1D work spread over x and y)
    uint count;        // items in this dispatch
    int z0;            // padded z layer of the first item
    int point_z0;      // padded point layer of the slab's first point
    int cell_z0;       // padded cell layer of the slab's first cell
    uint owned_point;  // slab index of the first point this slab owns
    uint owned_cell;   // slab index of the first cell this slab owns
    uint vertex_base;  // global id of the slab's first vertex
    uint mode;         // pass-specific
    int value_z0;      // padded point layer of the slab's first sample in `values`
    uint owned_point_end;  // slab index one past the last point this slab owns
    uint owned_cell_end;   // slab index one past the last cell this slab owns
    uint added_base;       // mc33: global number of the slab's first added vertex
    uint added_offset;     // mc33: output index of the slab's first added vertex
} C;

const uint INSIDE_BIT = 256u;
const uint EDGE_BITS = 255u;
// Dual methods: bit RING_MISSING << a set iff a cell around the crossed edge along axis a is
// missing (no quad there; classify.comp).
const uint RING_MISSING = 512u;

// The item of this invocation, or C.count when there is none.
uint item_index() {
    uint group = gl_WorkGroupID.x + gl_WorkGroupID.y * C.groups_x;
    uint i = group * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
    return min(i, C.count);
}

int pad() { return P.dims.w; }
// Padded points and cells per axis.
ivec3 np() { return P.dims.xyz + 2 * P.dims.w; }
ivec3 nc() { return np() - 1; }

// Coordinates of item `i` of a dispatch over layers of `extent.x * extent.y` starting at C.z0.
ivec3 item_coords(uint i, ivec2 extent) {
    uint layer = uint(extent.x * extent.y);
    uint k = i / layer;
    uint r = i - k * layer;
    uint j = r / uint(extent.x);
    return ivec3(int(r - j * uint(extent.x)), int(j), C.z0 + int(k));
}

// Padded point / cell at slab index `slot` (inverse of point_slot / cell_slot).
ivec3 point_at(uint slot) {
    uvec3 n = uvec3(np());
    uint layer = n.x * n.y;
    uint r = slot % layer;
    return ivec3(int(r % n.x), int(r / n.x), C.point_z0 + int(slot / layer));
}
ivec3 cell_at(uint slot) {
    uvec3 n = uvec3(nc());
    uint layer = n.x * n.y;
    uint r = slot % layer;
    return ivec3(int(r % n.x), int(r / n.x), C.cell_z0 + int(slot / layer));
}

// The owner of output item `target` (counted from the scan's value at the first owned slot):
// the last owned slot p with scan[p] <= target, found by bisection. The emit passes run one
// invocation per output item and find their owner this way, so their work follows the output,
// not the grid. Returns the slot and, in `rank`, the item's rank within its owner.
uint find_point(uint target, out uint rank) {
    uint lo = C.owned_point;
    uint hi = C.owned_point_end;
    target += point_scan[lo];
    while (hi - lo > 1u) {
        uint mid = lo + ((hi - lo) >> 1);
        if (point_scan[mid] <= target) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    rank = target - point_scan[lo];
    return lo;
}
uint find_cell(uint target, out uint rank) {
    uint lo = C.owned_cell;
    uint hi = C.owned_cell_end;
    target += cell_scan[lo];
    while (hi - lo > 1u) {
        uint mid = lo + ((hi - lo) >> 1);
        if (cell_scan[mid] <= target) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    rank = target - cell_scan[lo];
    return lo;
}

// Slab index of padded point q / padded cell c.
uint point_slot(ivec3 q) {
    ivec3 n = np();
    return uint(q.x + n.x * (q.y + n.y * (q.z - C.point_z0)));
}
uint cell_slot(ivec3 c) {
    ivec3 n = nc();
    return uint(c.x + n.x * (c.y + n.y * (c.z - C.cell_z0)));
}

// Offset of an edge family given as corner bits (x = 1, y = 2, z = 4).
ivec3 offset_of(uint bits) {
    return ivec3(int(bits & 1u), int((bits >> 1) & 1u), int((bits >> 2) & 1u));
}

// THE inside rule (Rust: `Inside::contains` with the f64 isovalue): `iso.x` is the f32 next to
// the isovalue on the side that makes `v < iso.x` (below) or `v > iso.x` (above) exactly the f64
// comparison for every f32 v. Equal is outside; NaN is outside.
bool inside_value(float v) {
    return P.iso.w > 0.0 ? v < P.iso.x : v > P.iso.x;
}

// Whether padded point q is a grid point.
bool is_real(ivec3 q) {
    return all(greaterThanEqual(q, ivec3(pad()))) && all(lessThan(q, P.dims.xyz + pad()));
}

// Sample at padded point q (a grid point within the slab's sample layers).
float value_at(ivec3 q) {
    ivec3 n = np();
    return values[q.x + n.x * (q.y + n.y * (q.z - C.value_z0))];
}

bool padded_inside(ivec3 q) {
    return is_real(q) && inside_value(value_at(q));
}

// Whether padded point q holds missing data (missing.glsl; padding points never do).
bool padded_missing(ivec3 q) {
    return is_real(q) && is_missing(value_at(q));
}

// Whether grid cell c (unpadded) is missing: a corner is missing data (`cell_missing`).
bool grid_cell_missing(ivec3 c) {
    for (uint n = 0u; n < 8u; n++) {
        if (is_missing(value_at(c + pad() + offset_of(n)))) return true;
    }
    return false;
}

// Global id of the vertex on the crossed lattice edge from padded point q along axis (x, y, z
// families: marching cubes and mc33).
uint edge_vertex(ivec3 q, uint axis) {
    uint slot = point_slot(q);
    uint below = point_mask[slot] & ((1u << axis) - 1u);
    return C.vertex_base + point_scan[slot] - point_scan[C.owned_point] + bitCount(below);
}


// The crossing parameter on an edge from value a to value b: (iso - a) / (b - a) clamped to
// [0, 1], 0.5 when NaN. The isovalue enters as hi + lo so that iso - a keeps its f64 digits
// where it cancels (hi - a is then exact).
float crossing(float a, float b) {
    precise float s = ((P.iso.y - a) + P.iso.z) / (b - a);
    return isnan(s) ? 0.5 : clamp(s, 0.0, 1.0);
}

// The crossing parameter on the edge from padded point q to q + d: both grid points: as above;
// a grid point to a padding point: pinned to the grid point (GEL's t = 0).
float padded_crossing(ivec3 q, ivec3 d) {
    ivec3 r = q + d;
    bool qr = is_real(q);
    bool rr = is_real(r);
    if (qr && rr) {
        return crossing(value_at(q), value_at(r));
    }
    return qr ? 0.0 : 1.0;
}

// World position of grid index-space point base + local (local summed last, so it keeps its
// digits however far base is from the origin). `precise` here and in the crossings: no fused
// multiply-adds, so every pass that computes a position gets the same bits.
vec3 world(ivec3 base, vec3 local) {
    precise vec3 w = (P.box_min.xyz + vec3(base) * P.spacing.xyz) + local * P.spacing.xyz;
    return w;
}

// Index-space gradient of the interpolant of grid cell c at local l (interp_gradient: the sum
// of products of `field::interpolant::trilinear::gradient`, the CPU meshes' normals).
vec3 cell_gradient(ivec3 c, vec3 l) {
    float v[8];
    for (int n = 0; n < 8; n++) {
        v[n] = value_at(c + pad() + offset_of(uint(n)));
    }
    return interp_gradient(corners_of(v), l);
}

// Index-space gradient at grid index-space point base + local (local in [0, 1]³), averaged over
// the cells that contain it (`Field::gradient`): along each axis a coordinate strictly between
// integers selects one cell; an integer coordinate inside the grid the two cells sharing that
// plane; on the grid's boundary plane the one cell there. Missing cells are left out; with
// none left, zero (the callers' fallback applies, as the CPU's NaN does).
vec3 gradient_at(ivec3 base, vec3 local) {
    ivec2 cells[3];
    vec2 locs[3];
    int counts[3];
    for (int a = 0; a < 3; a++) {
        int ncell = P.dims[a] - 1;
        float l = local[a];
        if (l == 0.0 || l == 1.0) {
            int g = base[a] + int(l);
            if (g > 0 && g < ncell) {
                cells[a] = ivec2(g - 1, g);
                locs[a] = vec2(1.0, 0.0);
                counts[a] = 2;
            } else {
                cells[a] = ivec2(g == 0 ? 0 : ncell - 1, 0);
                locs[a] = vec2(g == 0 ? 0.0 : 1.0, 0.0);
                counts[a] = 1;
            }
        } else {
            cells[a] = ivec2(base[a], 0);
            locs[a] = vec2(l, 0.0);
            counts[a] = 1;
        }
    }
    vec3 sum = vec3(0.0);
    int used = 0;
    for (int iz = 0; iz < counts[2]; iz++) {
        for (int iy = 0; iy < counts[1]; iy++) {
            for (int ix = 0; ix < counts[0]; ix++) {
                ivec3 c = ivec3(cells[0][ix], cells[1][iy], cells[2][iz]);
                if (grid_cell_missing(c)) continue;
                sum += cell_gradient(c, vec3(locs[0][ix], locs[1][iy], locs[2][iz]));
                used++;
            }
        }
    }
    return used == 0 ? vec3(0.0) : sum / float(used);
}

// Normalises v (scaled first, so tiny vectors do not underflow); false if zero or not finite.
bool unit(vec3 v, out vec3 n) {
    float m = max(abs(v.x), max(abs(v.y), abs(v.z)));
    n = vec3(0.0, 0.0, 1.0);
    if (!(m > 0.0) || isinf(m)) {
        return false;
    }
    v /= m;
    n = v / length(v);
    return true;
}

// The unit world-space normal, inside -> outside, at grid index-space point base + local
// (`Field::normal`): the averaged gradient over the spacing, negated for inside = above;
// where that vanishes the index-space direction `fallback` mapped to world space; else +z.
vec3 normal_at(ivec3 base, vec3 local, vec3 fallback) {
    vec3 g = P.iso.w * gradient_at(base, local) / P.spacing.xyz;
    vec3 n;
    if (unit(g, n)) {
        return n;
    }
    unit(fallback * P.spacing.xyz, n);
    return n;
}
