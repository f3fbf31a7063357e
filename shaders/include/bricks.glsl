// Empty-space skipping for the ray walks (analytic.comp and tricubic.comp over cells; voxels.comp
// reads the range test and the grid, with jumps of its own on voxel planes): the min/max grid's
// bricks and superbricks (built by bricks.comp),
// the test that a value range holds no crossing, and the jumps out of an empty brick or
// superbrick that land where the cell-by-cell walk would. analytic.comp's header says how that
// keeps images bit for bit the same. Needs `RenderParams P`, the ranges `vec2 bricks[]` (bricks,
// then superbricks) and BRICK, SUPER (build.rs); declares the specialization constants 0
// (BRICK_LEVELS) and 1 (SURFACE_COUNT).

#ifndef BRICKS_GLSL
#define BRICKS_GLSL

// A brick is skipped only when its whole value range is on one side of the isovalue by more
// than this, relative to the magnitudes involved. Every value the walk decides the predicate on
// inside a brick is a convex combination of the brick's corners (interp_value at segment ends)
// or the cubic evaluated at a derivative root; their f32 rounding errors are bounded by a few
// tens of FLT_EPSILON times (max |corner| + |iso|) (coefficients up to ~30 times the corner
// magnitude, Horner and coefficient rounding), about 2^-15 of it. 2^-10 leaves a factor of 30.
const float SKIP_MARGIN = 1.0 / 1024.0;

// Where the ray o + t d leaves cell index `c` across a plane of axis `a` (infinite along it).
float tmax_of(int a, int c, vec3 o, vec3 d) {
    if (d[a] > 0.0) return (float(c + 1) - o[a]) / d[a];
    if (d[a] < 0.0) return (float(c) - o[a]) / d[a];
    return uintBitsToFloat(0x7f800000u);
}

// Surface k's inside threshold (surface 0's is P.threshold).
float threshold(uint k) {
    return P.thresholds[k / 4u][k % 4u];
}

// The levels of the min/max grid the walk jumps with: 1 (bricks) or 2 (and superbricks). A
// specialization constant, set per render (render/mod.rs: where superbricks are empty enough),
// so that a walk without superbricks carries none of their code: llvmpipe pays for it in the
// walk's loop even when never taken (~15% on the 256^3 gyroid).
layout(constant_id = 0) const int BRICK_LEVELS = 1;

// The number of surfaces (P.surfaces), also a specialization constant: the loops over surfaces in
// the walk (brick, superbrick and cell tests, the crossings) then have a constant trip count and
// constant indices into P.thresholds; with the uniform count they cost llvmpipe about a third
// of the 256^3 gyroid's render (574 -> 394 ms) and a sixth of the torus's.
layout(constant_id = 1) const uint SURFACE_COUNT = 1u;

// Cells per superbrick edge.
const int SUPER_CELLS = BRICK * SUPER;

// Whether the field's values in a region whose grid values lie in `mm` are clearly on one side
// of every isovalue: no crossing of any surface can lie there. Monotone: a range inside a
// range that passes passes too (its tolerance is no larger), so every brick of a superbrick
// that passes does.
bool range_is_empty(vec2 mm) {
    for (uint k = 0u; k < SURFACE_COUNT; k++) {
        float iso = threshold(k);
        float tol = SKIP_MARGIN * (max(abs(mm.x), abs(mm.y)) + abs(iso));
        if (!(mm.x - iso > tol || iso - mm.y > tol)) return false;
    }
    return true;
}

#ifdef CELL_TESTS
// The trilinear walk's per-cell tests (analytic.comp, occupancy/masks.comp: the same
// functions, so the masks hold exactly the walk's decisions). Needs field.glsl's Corners.
// The same test on the smallest and largest of the corners (any order of min and max gives
// the same exact values: the mask pass takes them separably).
bool values_clear(float lo, float hi, float iso) {
    float tol = SKIP_MARGIN * (max(abs(lo), abs(hi)) + abs(iso));
    return lo - iso > tol || iso - hi > tol;
}

// The same test for one cell (`render.skip` too): every value the walk decides the predicate on
// in the cell (the carried entry value, the exit value, the cubic at its split points) is a
// convex combination of its 8 corners up to rounding, so a cell whose corners are clearly on one
// side holds no crossing and its cubic need not be formed. Changes no output, `steps` included.
bool cell_is_clear(Corners k, float iso) {
    vec4 mn = min(k.lo, k.hi);
    vec4 mx = max(k.lo, k.hi);
    float lo = min(min(mn.x, mn.y), min(mn.z, mn.w));
    float hi = max(max(mx.x, mx.y), max(mx.z, mx.w));
    return values_clear(lo, hi, iso);
}


// Whether every surface is clear of the cell (cell_is_clear): no crossing can lie in it.
bool cell_all_clear(Corners k) {
    for (uint s = 0u; s < SURFACE_COUNT; s++) {
        if (!cell_is_clear(k, threshold(s))) return false;
    }
    return true;
}
#endif

// Bricks per axis: ceil(cells / BRICK).
ivec3 brick_counts() {
    return (P.dims - 2) / BRICK + 1;
}

// Whether no crossing of any surface can lie in the brick of `cell`.
bool brick_is_empty(ivec3 cell) {
    // BRICK as a constant (RenderParams has no brick size): llvmpipe has no vector integer
    // division, and a division by a variable costs it one scalar division per lane.
#ifdef GRID_POOL
    // The pool's hierarchical tables (field.glsl).
    return range_is_empty(pool_brick_range(cell / BRICK));
#else
    ivec3 nb = brick_counts();
    ivec3 b = cell / BRICK;
    return range_is_empty(bricks[(b.z * nb.y + b.y) * nb.x + b.x]);
#endif
}

// The same for the superbrick of `cell` (their ranges follow the bricks').
bool superbrick_is_empty(ivec3 cell) {
#ifdef GRID_POOL
    // The pool's tables start with the superbricks (field.glsl).
    return range_is_empty(bricks[pool_super(cell / BRICK)]);
#else
    ivec3 nb = brick_counts();
    ivec3 ns = (nb - 1) / SUPER + 1;
    ivec3 s = cell / SUPER_CELLS;
    return range_is_empty(bricks[nb.x * nb.y * nb.z + (s.z * ns.y + s.y) * ns.x + s.x]);
#endif
}

#ifndef GRID_POOL
// The same for the fine brick (FINE^3 cells) of `cell`: the tricubic grids' finer level, after
// the superbricks (passes/bricks.rs's layout; no pool or block reads it).
bool fine_brick_is_empty(ivec3 cell) {
    ivec3 nb = brick_counts();
    ivec3 ns = (nb - 1) / SUPER + 1;
    ivec3 nf = (P.dims - 2) / FINE + 1;
    ivec3 f = cell / FINE;
    int first = nb.x * nb.y * nb.z + ns.x * ns.y * ns.z;
    return range_is_empty(bricks[first + (f.z * nf.y + f.y) * nf.x + f.x]);
}
#endif

// Defined at the end, below the jumps that use it: that order keeps the SPIR-V (stripped of
// debug info) what it was before these helpers left analytic.comp.
int last_in_block(int a, int c, bool whole, vec3 d);
float leave_cells(inout ivec3 cell, inout vec3 tmax, float t_hi, vec3 o, vec3 d,
                  ivec3 last_cell);

// The passes the walk with bricks alone makes from `cell` (at t_in, its brick empty) until it
// leaves the superbrick, `whole`, or ends: one per brick jump, the jump out of each brick it
// crosses. Its jumps end where the ray leaves a brick, the nearest next brick plane of the
// three axes (several planes at the same t: one jump), so the bricks follow in the order of a
// brick-by-brick walk, whose planes' t are the same tmax_of expressions as leave_brick's.
uint brick_jumps(ivec3 cell, float t_hi, vec3 o, vec3 d) {
    ivec3 last;    // per axis, the last cell of the current brick
    vec3 t_next;   // per axis, where the ray leaves the current brick
    float t_end = t_hi;  // where it leaves the superbrick, or ends
    for (int a = 0; a < 3; a++) {
        last[a] = last_in_block(a, cell[a], false, d);
        t_next[a] = tmax_of(a, last[a], o, d);
        t_end = min(t_end, tmax_of(a, last_in_block(a, cell[a], true, d), o, d));
    }
    uint jumps = 1u;
    for (int i = 0; i < 3 * SUPER; i++) {
        float t_b = min(t_next.x, min(t_next.y, t_next.z));
        if (t_b >= t_end) break;
        jumps++;
        for (int a = 0; a < 3; a++) {
            if (t_next[a] <= t_b) {
                last[a] = last_in_block(a, last[a] + (d[a] > 0.0 ? 1 : -1), false, d);
                t_next[a] = tmax_of(a, last[a], o, d);
            }
        }
    }
    return jumps;
}

// Leaves the brick (BRICK^3 cells) holding `cell`, or its superbrick when `whole` (leave_cells).
float leave_brick(inout ivec3 cell, inout vec3 tmax, float t_hi, vec3 o, vec3 d, bool whole) {
    ivec3 last_cell;
    for (int a = 0; a < 3; a++) last_cell[a] = last_in_block(a, cell[a], whole, d);
    return leave_cells(cell, tmax, t_hi, o, d, last_cell);
}

// The last cell, per axis in travel order, of the cube of `size` cells from `first` (clamped to
// the grid): what leave_cells leaves. A zero direction component stays in `cell`'s index.
ivec3 block_last(ivec3 first, int size, ivec3 cell, vec3 d) {
    ivec3 last;
    for (int a = 0; a < 3; a++) {
        if (d[a] > 0.0) {
            last[a] = min(first[a] + size - 1, P.dims[a] - 2);
        } else if (d[a] < 0.0) {
            last[a] = max(first[a], 0);
        } else {
            last[a] = cell[a];
        }
    }
    return last;
}

// A cell's bit in its brick's occupancy mask (passes/occupancy.rs): the Morton order of its
// coordinates in the brick (x0 y0 z0 x1 y1 z1 x2 y2 z2, lowest first), so that each 2^3 block of
// cells is 8 consecutive bits and each 4^3 block 64 (two words).
uint mask_bit(ivec3 l) {
    uint m = 0u;
    for (int k = 0; k < 3; k++) {
        m |= uint((l.x >> k) & 1) << uint(3 * k);
        m |= uint((l.y >> k) & 1) << uint(3 * k + 1);
        m |= uint((l.z >> k) & 1) << uint(3 * k + 2);
    }
    return m;
}

// The cell of Morton index m in its brick (mask_bit's inverse).
ivec3 mask_cell(uint m) {
    ivec3 l = ivec3(0);
    for (int k = 0; k < 3; k++) {
        l.x |= int((m >> uint(3 * k)) & 1u) << k;
        l.y |= int((m >> uint(3 * k + 1)) & 1u) << k;
        l.z |= int((m >> uint(3 * k + 2)) & 1u) << k;
    }
    return l;
}

// Leaves the box of cells from `cell` to `last_cell` (per axis the last cell in travel order):
// returns t_b, where the ray leaves it (at most t_hi), and puts `cell` and `tmax` in the cell the
// cell-by-cell walk is in when its segment ends at t_b. That walk crosses every plane whose tmax
// is below t_b, each at its own t, so it is then in the cell whose per-axis index is the first
// (in travel order) with tmax >= t_b: found from the position at t_b, corrected against the
// tmax of the planes on either side. Needs tmax strictly increasing along each axis (may_jump)
// and min(tmax) > t_in.
float leave_cells(inout ivec3 cell, inout vec3 tmax, float t_hi, vec3 o, vec3 d,
                  ivec3 last_cell) {
    float t_b = t_hi;
    for (int a = 0; a < 3; a++) t_b = min(t_b, tmax_of(a, last_cell[a], o, d));
    if (t_b >= t_hi) return t_b;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0) continue;
        int s = d[a] > 0.0 ? 1 : -1;
        float x = o[a] + t_b * d[a];
        int c = s > 0 ? int(floor(x)) : int(ceil(x)) - 1;
        c = s > 0 ? clamp(c, cell[a], last_cell[a]) : clamp(c, last_cell[a], cell[a]);
        for (int i = 0; i <= SUPER_CELLS && c != cell[a] && tmax_of(a, c - s, o, d) >= t_b; i++)
            c -= s;
        for (int i = 0; i <= SUPER_CELLS && c != last_cell[a] && tmax_of(a, c, o, d) < t_b; i++)
            c += s;
        cell[a] = c;
        tmax[a] = tmax_of(a, c, o, d);
    }
    return t_b;
}

// The last cell, in travel order along axis `a`, of the brick holding cell index `c`, or of its
// superbrick when `whole` (blocks aligned to multiples of their size, the last one partial).
int last_in_block(int a, int c, bool whole, vec3 d) {
    // Constant divisors: brick_is_empty says why.
    int first = whole ? (c / SUPER_CELLS) * SUPER_CELLS : (c / BRICK) * BRICK;
    int size = whole ? SUPER_CELLS : BRICK;
    return d[a] > 0.0 ? min(first + size - 1, P.dims[a] - 2) : (d[a] < 0.0 ? first : c);
}

#endif
