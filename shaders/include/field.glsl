// The trilinear field on the grid, read exactly with texelFetch (no hardware filtering: real
// GPUs filter with ~8-bit weights). Mirrors `reference::field` (f64).
// Needs: `RenderParams P` and `sampler3D u_grid` declared before inclusion; with GRID_BUFFER
// instead `float grid[]` (the whole grid, not a block); with GRID_POOL
// (`field.residency = "active"`, render/pool.rs) instead `float pool[]`, `uint pages[]` and
// `vec2 bricks[]`.
//
// Every read of a grid point names the cell it is read for (`cell_value(c, p)`): with the pool,
// the point is read from the slot of that cell's brick, which holds the brick's points and
// POOL_APRON more on every side (the central differences of smooth normals at the brick's
// points), so a cell never needs a second brick.

#include "missing.glsl"
#include "interpolant.glsl"

// THE inside rule (Rust: `Inside::contains`): strictly below (or above) is inside; equal is
// outside.
// The inside predicate against one surface's threshold (P.thresholds; surface 0's is
// P.threshold).
bool inside_of(float v, float threshold) {
    return P.inside_sign > 0.0 ? v < threshold : v > threshold;
}

// The surfaces inside_mask tests: P.surfaces, or a constant the including shader defines
// (raymarch.comp's specialization constant), over which the loop is unrolled.
#ifndef SURFACES_TESTED
#define SURFACES_TESTED P.surfaces
#endif

// Bit k set: v is inside surface k (k < P.surfaces).
uint inside_mask(float v) {
    uint m = 0u;
    for (uint k = 0u; k < SURFACES_TESTED; k++) {
        if (inside_of(v, P.thresholds[k / 4u][k % 4u])) m |= 1u << k;
    }
    return m;
}

#ifdef GRID_POOL
// Points per edge of a pool slot.
const int SLOT = BRICK + 1 + 2 * POOL_APRON;

// The pool's tables are hierarchical (render/pool.rs, `Residency`): pages[] holds, per
// superbrick (SUPER^3 bricks), its block or NO_PAGE, then POOL_BLOCK entries per block, a
// brick's slot or NO_PAGE; bricks[] holds the ranges in the same layout. A superbrick without a
// block is clear of every isovalue and its bricks read as its range.
const int POOL_BLOCK = SUPER * SUPER * SUPER;

// Superbricks per axis.
ivec3 pool_supers() {
    ivec3 nb = (P.dims - 2) / BRICK + 1;  // bricks per axis: ceil(cells / BRICK)
    return (nb - 1) / SUPER + 1;
}

// The superbrick of brick b.
int pool_super(ivec3 b) {
    ivec3 ns = pool_supers();
    ivec3 s = b / SUPER;
    return (s.z * ns.y + s.y) * ns.x + s.x;
}

// Brick b's entry in the blocks' part of pages[] and bricks[], or -1 when its superbrick has
// no block.
int pool_entry(ivec3 b) {
    uint block = pages[pool_super(b)];
    if (block == NO_PAGE) return -1;
    ivec3 ns = pool_supers();
    ivec3 l = b - (b / SUPER) * SUPER;
    return ns.x * ns.y * ns.z + int(block) * POOL_BLOCK + (l.z * SUPER + l.y) * SUPER + l.x;
}

// Brick b's value range: its own, or its superbrick's.
vec2 pool_brick_range(ivec3 b) {
    int e = pool_entry(b);
    return e < 0 ? bricks[pool_super(b)] : bricks[e];
}

// The page table entry of the brick holding `cell`: its slot in the pool, or NO_PAGE.
uint page_of(ivec3 cell) {
    int e = pool_entry(cell / BRICK);
    return e < 0 ? NO_PAGE : pages[e];
}

// Whether the pool holds the brick of `cell`.
bool resident(ivec3 cell) {
    return page_of(cell) != NO_PAGE;
}

// Grid point p, read for a cell c of a resident brick (p within POOL_APRON of c's brick). A
// cell of a brick not in the pool reads as the brick's minimum: every value in such a brick is
// on the same side of every isovalue as it (render/pool.rs says where that matters).
float cell_value(ivec3 c, ivec3 p) {
    uint slot = page_of(c);
    ivec3 b = c / BRICK;
    if (slot == NO_PAGE) return pool_brick_range(b).x;
    // Clamped: a smooth normal on a brick's far face reads one point past the apron with
    // weight 0 (see smooth_gradient); any finite value leaves it unchanged.
    ivec3 l = clamp(p - (b * BRICK - POOL_APRON), ivec3(0), ivec3(SLOT - 1));
    return pool[int(slot) * SLOT * SLOT * SLOT + (l.z * SLOT + l.y) * SLOT + l.x];
}
#elif defined(GRID_BUFFER)
// The whole grid in a storage buffer (`grid[]`, x fastest; render/mod.rs): llvmpipe reads a
// buffer element with a fraction of the instructions of a texelFetch.
int grid_index(ivec3 p) {
    return (p.z * P.dims.y + p.y) * P.dims.x + p.x;
}

float cell_value(ivec3 c, ivec3 p) {
    return grid[grid_index(p)];
}
#else
// The value at grid point p (global indices; u_grid may hold only a block of the grid, from
// P.block_origin on), read for cell c (any cell: the image holds every point).
float cell_value(ivec3 c, ivec3 p) {
    return texelFetch(u_grid, p - P.block_origin, 0).r;
}
#endif

// World position -> continuous grid coordinates, clamped into the box.
vec3 to_grid(vec3 pos) {
    return clamp((pos - P.box_min) * P.inv_spacing, vec3(0.0), vec3(P.dims - 1));
}

// The cell holding grid coordinates u: floor, clamped so the last grid plane belongs to the
// last cell.
ivec3 cell_of(vec3 u) {
    return clamp(ivec3(floor(u)), ivec3(0), P.dims - 2);
}

#ifdef GRID_POOL
// One page lookup for the 8 corners (they are all in c's slot).
Corners cell_corners(ivec3 c) {
    Corners k;
    ivec3 b = c / BRICK;
    int e = pool_entry(b);
    uint slot = e < 0 ? NO_PAGE : pages[e];
    if (slot == NO_PAGE) {
        float v = e < 0 ? bricks[pool_super(b)].x : bricks[e].x;
        k.lo = vec4(v);
        k.hi = vec4(v);
        return k;
    }
    ivec3 l = c - (b * BRICK - POOL_APRON);
    const int SY = SLOT;
    const int SZ = SLOT * SLOT;
    int i = int(slot) * SLOT * SZ + l.z * SZ + l.y * SY + l.x;
    k.lo = vec4(pool[i], pool[i + 1], pool[i + SY], pool[i + SY + 1]);
    k.hi = vec4(pool[i + SZ], pool[i + SZ + 1], pool[i + SZ + SY], pool[i + SZ + SY + 1]);
    return k;
}
#elif defined(GRID_BUFFER)
Corners cell_corners(ivec3 c) {
    Corners k;
    int sy = P.dims.x;
    int sz = P.dims.x * P.dims.y;
    int i = grid_index(c);
    k.lo = vec4(grid[i], grid[i + 1], grid[i + sy], grid[i + sy + 1]);
    k.hi = vec4(grid[i + sz], grid[i + sz + 1], grid[i + sz + sy], grid[i + sz + sy + 1]);
    return k;
}
#else
Corners cell_corners(ivec3 c) {
    Corners k;
    k.lo = vec4(cell_value(c, c), cell_value(c, c + ivec3(1, 0, 0)),
                cell_value(c, c + ivec3(0, 1, 0)), cell_value(c, c + ivec3(1, 1, 0)));
    k.hi = vec4(cell_value(c, c + ivec3(0, 0, 1)), cell_value(c, c + ivec3(1, 0, 1)),
                cell_value(c, c + ivec3(0, 1, 1)), cell_value(c, c + ivec3(1, 1, 1)));
    return k;
}
#endif

// Whether the cell of corners k is missing (missing.glsl: a corner is NaN or infinite).
bool cell_missing(Corners k) {
    return corners_missing(k.lo, k.hi);
}




#if defined(INTERP_CUBIC)
// The loops over a cell's 64 samples unrolled where the including shader asks (tricubic.comp
// says why), as the fixed-step march does.
#ifndef CUBIC_UNROLL
#define CUBIC_UNROLL
#endif
// The fixed-step march's field for `interpolation = "cubic-bspline" | "catmull-rom"` (the
// raymarch variants that define INTERP_BSPLINE or INTERP_CATMULL_ROM, interpolant.glsl): the
// cell's 4x4x4 samples, indices clamped to the grid (the contract's edge clamp; the whole grid
// is in u_grid: fixed-step reads no block), and a cell is missing when any of them is.

// A cell whose samples were fetched last; marching reuses it while samples stay in the cell.
struct CellCache {
    ivec3 cell;
    Samples k;
    bool missing;
};

CellCache cache_empty() {
    CellCache c;
    c.cell = ivec3(-1);
    for (int n = 0; n < 64; n++) {
        c.k.s[n] = 0.0;
    }
    c.missing = false;
    return c;
}

Samples cell_samples(ivec3 c) {
    Samples k;
    CUBIC_UNROLL for (int n = 0; n < 64; n++) {
        ivec3 p = clamp(c + ivec3(n & 3, (n >> 2) & 3, n >> 4) - 1, ivec3(0), P.dims - 1);
        k.s[n] = cell_value(c, p);
    }
    return k;
}

bool samples_missing(Samples k) {
    bool m = false;
    CUBIC_UNROLL for (int n = 0; n < 64; n++) {
        m = m || is_missing(k.s[n]);
    }
    return m;
}

// Field value at grid coordinates u (already inside the box), through the cache; afterwards
// `cache.missing` says whether u's cell is missing.
float field_cached(inout CellCache cache, vec3 u) {
    ivec3 c = cell_of(u);
    if (c != cache.cell) {
        cache.cell = c;
        cache.k = cell_samples(c);
        cache.missing = samples_missing(cache.k);
    }
    return cubic_value(cache.k, u - vec3(c));
}

// Unit world-space normal at grid coordinates u, pointing from inside to outside (the exact
// gradient of the interpolant); `fallback` where the gradient vanishes.
vec3 normal_at(vec3 u, vec3 fallback) {
    ivec3 c = cell_of(u);
    vec3 g = cubic_gradient(cell_samples(c), u - vec3(c)) * P.inv_spacing * P.inside_sign;
    return unit_or(g, fallback);
}
#elif defined(INTERP_DEVICE)
// The fixed-step march's field for `interpolation = "device"` (the raymarch variant that
// defines INTERP_DEVICE): whatever the texture unit returns for a linear-filtered lookup of
// u_grid (bound with its linear sampler, CLAMP_TO_EDGE), point p's texel centred at p. A
// sample is missing when the filtered value is not finite. Not a cell's interpolant: there
// is nothing to cache but the missing flag.
struct CellCache {
    bool missing;
};

CellCache cache_empty() {
    CellCache c;
    c.missing = false;
    return c;
}

float device_value(vec3 u) {
    return texture(u_grid, (u + 0.5) / vec3(P.dims)).r;
}

float field_cached(inout CellCache cache, vec3 u) {
    float v = device_value(u);
    cache.missing = is_missing(v);
    return v;
}

// The normal a shader takes of its own lookups (Rust: `DeviceModel::gradient_at`): central
// differences at +-1/64 cell along each axis, coordinates clamped into the box as the march's
// are, inside to outside; `fallback` where they vanish.
const float DEVICE_DELTA = 1.0 / 64.0;

vec3 normal_at(vec3 u, vec3 fallback) {
    vec3 hi = vec3(P.dims - 1);
    vec3 g;
    for (int a = 0; a < 3; a++) {
        vec3 e = vec3(0.0);
        e[a] = DEVICE_DELTA;
        g[a] = (device_value(clamp(u + e, vec3(0.0), hi)) - device_value(clamp(u - e, vec3(0.0), hi)))
               / (2.0 * DEVICE_DELTA);
    }
    g *= P.inv_spacing * P.inside_sign;
    return unit_or(g, fallback);
}
#else
// A cell whose corners were fetched last; marching reuses it while samples stay in the cell.
// `missing`: the cell is missing (cell_missing), tested once per cell; with INTERP_NEAREST
// (the raymarch variant of `interpolation = "nearest"`) whether the sample's own voxel is,
// tested per sample: a voxel beside a missing one keeps its value.
struct CellCache {
    ivec3 cell;
    Corners k;
    bool missing;
};

CellCache cache_empty() {
    CellCache c;
    c.cell = ivec3(-1);
    c.k.lo = vec4(0.0);
    c.k.hi = vec4(0.0);
    c.missing = false;
    return c;
}

// Field value at grid coordinates u (already inside the box), through the cache; afterwards
// `cache.missing` says whether u's cell is missing.
float field_cached(inout CellCache cache, vec3 u) {
    ivec3 c = cell_of(u);
#ifdef INTERP_NEAREST
    if (c != cache.cell) {
        cache.cell = c;
        cache.k = cell_corners(c);
    }
    float v = nearest_value(cache.k, u - vec3(c));
    cache.missing = is_missing(v);
    return v;
#else
    if (c != cache.cell) {
        cache.cell = c;
        cache.k = cell_corners(c);
        cache.missing = cell_missing(cache.k);
    }
    return interp_value(cache.k, u - vec3(c));
#endif
}

// Field value at grid coordinates u (already inside the box).
float field_at(vec3 u) {
    ivec3 c = cell_of(u);
    return interp_value(cell_corners(c), u - vec3(c));
}

// Unit world-space normal at grid coordinates u, pointing from inside to outside; `fallback`
// where the gradient vanishes.
vec3 normal_at(vec3 u, vec3 fallback) {
    ivec3 c = cell_of(u);
    vec3 g = interp_gradient(cell_corners(c), u - vec3(c)) * P.inv_spacing * P.inside_sign;
    return unit_or(g, fallback);
}
#endif

#ifdef INTERP_NEAREST
// The point whose voxel holds grid coordinates u (Rust: `nearest::voxel_of`): the corner
// nearest_corner picks in u's cell.
ivec3 voxel_of(vec3 u) {
    ivec3 c = cell_of(u);
    return c + ivec3(greaterThanEqual(u - vec3(c), vec3(0.5)));
}

// `nearest`'s face at a refined bracket (Rust: `fixed_step::voxel_face`): the normal from the
// inside voxel to the outside one across the lowest axis along which their points differ
// (`fallback` with none), and the inside voxel's point.
vec3 voxel_face(vec3 ua, vec3 ub, bool a_inside, vec3 fallback, out ivec3 vin) {
    ivec3 va = voxel_of(ua), vb = voxel_of(ub);
    vin = a_inside ? va : vb;
    ivec3 vout = a_inside ? vb : va;
    for (int a = 0; a < 3; a++) {
        if (vin[a] != vout[a]) {
            vec3 n = vec3(0.0);
            n[a] = vout[a] > vin[a] ? 1.0 : -1.0;
            return n;
        }
    }
    return fallback;
}
#endif

// `render.normals = "smooth"` (Rust: `reference::field::smooth_gradient_at`): the gradient at
// grid point p by central differences in index units, one-sided on the box's faces (its points
// read for cell c).
vec3 point_gradient(ivec3 c, ivec3 p) {
    ivec3 last = P.dims - 1;
    vec3 g;
    for (int a = 0; a < 3; a++) {
        ivec3 e = ivec3(0);
        e[a] = 1;
        ivec3 lo = p[a] == 0 ? p : p - e;
        ivec3 hi = p[a] == last[a] ? p : p + e;
        float w = (p[a] == 0 || p[a] == last[a]) ? 1.0 : 0.5;
        g[a] = (cell_value(c, hi) - cell_value(c, lo)) * w;
    }
    return g;
}

// The point gradients of u's cell interpolated at u component by component (`interp_value3`:
// the interpolant's order, as `reference::field::smooth_gradient_at`), in world units. The
// points are read for cell `via`, the cell the hit was found in: u's cell (cell_of) is `via`
// or, for a hit on via's far face, its neighbour across it, whose far points then weigh 0 and
// whose other points are within POOL_APRON of via's brick.
vec3 smooth_gradient(ivec3 via, vec3 u) {
    ivec3 c = cell_of(u);
    vec3 g[8];
    for (int n = 0; n < 8; n++) {
        g[n] = point_gradient(via, c + ivec3(n & 1, (n >> 1) & 1, n >> 2));
    }
    return interp_value3(g, u - vec3(c)) * P.inv_spacing;
}

// The normal the scene asks for at grid coordinates u (a hit found in cell `via`), given the
// exact one: unchanged for "trilinear"; for "smooth" the interpolated point gradient, inside to
// outside, or `exact` where it vanishes.
vec3 scene_normal(vec3 u, ivec3 via, vec3 exact) {
    if (P.normals != NORMALS_SMOOTH) return exact;
    vec3 g = smooth_gradient(via, u) * P.inside_sign;
    return unit_or(g, exact);
}

// Ray/box intersection (slabs). Returns false when the ray misses the box or the box lies
// behind the eye; else [t0, t1] with t0 >= 0. Zero direction components are handled
// explicitly instead of relying on 1/0.
bool clip_box(vec3 o, vec3 d, out float t0, out float t1) {
    t0 = 0.0;
    t1 = 3.402823466e38;
    for (int a = 0; a < 3; a++) {
        float lo = P.box_min[a];
        float hi = P.box_max[a];
        if (d[a] == 0.0) {
            if (o[a] < lo || o[a] > hi) return false;
        } else {
            float ta = (lo - o[a]) / d[a];
            float tb = (hi - o[a]) / d[a];
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    return t0 <= t1;
}
