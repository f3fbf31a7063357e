#version 450
// Exact ray tracing of the trilinear isosurface (`render.method = "analytic"`): the f32 port of
// `reference::analytic` (f64), whose module doc is the specification. The numbers below are the
// steps of its per-ray algorithm:
//   1. index space; 2. slab clip to [t_lo, t_hi]; 3. entry point; 4. first cell; 5. next planes
//   from plane indices; 6. walk the cells: per cell the cubic of the segment, split at the roots
//   of its derivative, a crossing wherever the inside predicate changes between consecutive
//   split points (values at cell faces: the same from both cells), refined by Newton kept in
//   the bracket; 7. hit attributes.
// With `render.count_crossings` (`P.count_crossings`) the walk goes on after the hit to count
// every crossing (the `crossings` channel; only the wanted one, `P.crossing`, the k-th, is
// refined); without it the walk stops at the wanted crossing and `crossings` is -1 (no channel).
//
// Outputs: the hit's colour (shade()), normal, depth (the ray's t: distance, dir being a unit
// vector), position, cell; `crossings`, every crossing with t > 0 inside the box; `steps`, the
// passes of the walk up to and including the hit's (all of them on a miss). Without skipping a
// pass is one cell, as the reference's `cells_visited`; with skipping a brick crossed in one jump
// is one pass, and a ray whose remaining span lies in an empty brick stops there.
//
// Empty-space skipping (`P.skip`; the brick helpers are include/bricks.glsl's): `bricks[]`
// holds the [min, max] of the corner values of each brick of BRICK^3 cells (built by
// bricks.comp). When the walk enters a cell whose brick is clearly on one side of every
// isovalue, it jumps to the cell of the brick where the ray leaves it (`leave_brick`), landing
// in exactly the cell and t the cell-by-cell walk reaches there; a cell whose corners are
// clearly on one side is stepped over without its cubic. The cells it does evaluate get the
// same numbers as in the cell-by-cell walk (see 6a/6b in main), so the image is bit for bit the
// same; rays for which a jump is not exact (`may_jump`) step cell by cell. A second level
// (BRICK_LEVELS = 2), superbricks of SUPER^3 bricks with their ranges after the bricks' in
// `bricks[]`, makes a stretch of empty bricks one jump; it counts as the brick jumps it replaces
// (`brick_jumps`), so `steps` does not depend on the levels either.
//
// Missing data (field.nan = "empty"): a cell with a NaN or infinite corner (field.glsl's
// cell_missing) is walked but never a candidate, as the reference skips its 6.2-6.5; the brick
// ranges hold finite samples only (bricks.comp), so the skipping stays exact.
//
// The whole grid is read from a storage buffer (`GRID_BUFFER`, the default), an MPI rank's block
// from the grid image, a brick pool (`GRID_POOL`) through its page table: field.glsl.
//
// Where f32 needs care (the reference is free of tolerances except CONVERGED):
// - the predicate is decided on g = f - iso as in the reference (`inside_g`);
// - CONVERGED = 4 FLT_EPSILON (analytic.glsl);
// - lerps are `precise`, so face values are exact at local 0 and 1;
// - `tmax` values are always computed from plane indices, never accumulated, so ties (rays
//   through edges and corners) are exact float equalities and the last cell's tmax is the
//   slab's far t.

#extension GL_GOOGLE_include_directive : require
#if defined(OCC_SKIP)
#extension GL_KHR_shader_subgroup_ballot : require
#endif

layout(local_size_x = RAY_GROUP, local_size_y = RAY_GROUP) in;  // build.rs

#include "params.glsl"
#include "pixel.glsl"

#ifdef OCC_SKIP
// RenderParams as a storage buffer, not a uniform one: lavapipe (Mesa 22) compiles a variant of
// a pipeline for each dispatch whose uniforms it can inline into the code, and frees them only
// with the pipeline; storage buffers it never inlines, so this pass is compiled once (render
// --frames kept growing by its variants).
layout(std140, binding = 0) readonly buffer Params { RenderParams P; };
#else
layout(std140, binding = 0) uniform Params { RenderParams P; };
#endif
#ifdef GRID_POOL
// `field.residency = "active"` (render/pool.rs): the grid's resident bricks, one slot of
// (BRICK + 1 + 2 POOL_APRON)^3 points each, and the page table of every brick.
layout(std430, binding = 1) readonly buffer Pool { float pool[]; };
layout(std430, binding = 5) readonly buffer Pages { uint pages[]; };
#elif defined(GRID_BUFFER)
// The whole grid's points, x fastest (a copy of the grid image; render/mod.rs).
layout(std430, binding = 1) readonly buffer Grid { float grid[]; };
#else
layout(binding = 1) uniform sampler3D u_grid;
#endif
layout(std430, binding = 2) writeonly buffer Out { Pixel pixels[]; };
layout(std430, binding = 3) readonly buffer Colormap { vec4 colormap[256]; };
layout(std430, binding = 4) readonly buffer Bricks { vec2 bricks[]; };
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;
#ifdef OCCUPANCY
// The occupancy structure (passes/occupancy.rs): per brick the distance in bricks to the nearest
// brick that may hold a surface (0: this one may), and per such brick one bit per cell, set
// where the cell is a candidate (the walk's own cell tests, made once per isovalue).
layout(std430, binding = 5) readonly buffer Reach { uint reaches[]; };
layout(std430, binding = 6) readonly buffer Masks { uint masks[]; };
#if defined(OCC_SKIP) || defined(OCC_RESUME)
// The walk in two passes (passes/occupancy.rs): OCC_SKIP, over every pixel, makes the walk's
// first jumps (the empty bricks from the ray's start) and either writes the pixel's miss record
// (the ray met no brick that may hold a surface) or lists the ray with the walk's state there;
// OCC_RESUME, over the listed rays only (an indirect dispatch), goes on from that state. The
// same walk, split where llvmpipe's cost is: it runs a shader's whole body for every group of
// 8 invocations, so the cell walk and the hit's code then run only for rays that need them.
// A listed ray: (pixel, cell.xyz), (t_in bits, passes, entered axes (bits 0-2) | jumped (bit 3)).
layout(std430, binding = 7) buffer Listed { uvec4 listed[]; };
layout(std430, binding = 8) buffer Count { uint count; uint groups_x; uint groups_y; uint groups_z; };
#endif
#endif

#include "field.glsl"
#include "shade.glsl"
#include "camera.glsl"
#include "clip.glsl"
#include "analytic.glsl"

#define CELL_TESTS
#include "bricks.glsl"

// 6.1 Where the segment of a cell entered at t_in ends: its nearest plane, or the ray's end.
float segment_end(vec3 tmax, float t_in, float t_hi) {
    return max(min(min(tmax.x, min(tmax.y, tmax.z)), t_hi), t_in);
}

// Local coordinate `a` of the ray's point at t in `cell`: the one expression for the exit point
// of a cell (6.2) and the entry point of the next (entry_point), so both have the same bits.
float local_at(int a, float t, ivec3 cell, vec3 o, vec3 d) {
    return clamp(o[a] + t * d[a] - float(cell[a]), 0.0, 1.0);
}

// Local coordinate `a` of the face a ray crossing planes of axis `a` enters a cell through.
float entry_face(int a, vec3 d) {
    return d[a] > 0.0 ? 0.0 : 1.0;
}

// 6.2 The exit point of the segment [t_in, t_out] of `cell` in local coordinates: exactly on
// the face for a crossed axis.
vec3 exit_point(bvec3 crossed, ivec3 cell, vec3 q_in, float t_in, float t_out, vec3 o, vec3 d) {
    vec3 q_out;
    for (int a = 0; a < 3; a++) {
        if (crossed[a]) {
            q_out[a] = d[a] > 0.0 ? 1.0 : 0.0;
        } else if (t_out == t_in) {
            q_out[a] = q_in[a];
        } else {
            q_out[a] = local_at(a, t_out, cell, o, d);
        }
    }
    return q_out;
}

// The local entry point of a cell entered at t_in > its previous cell's t_in across the planes
// of `entered`: what 6.6 carries from the previous cell's exit_point (1 - q on the crossed axes).
vec3 entry_point(bvec3 entered, ivec3 cell, float t_in, vec3 o, vec3 d) {
    vec3 q;
    for (int a = 0; a < 3; a++) {
        q[a] = entered[a] ? entry_face(a, d) : local_at(a, t_in, cell, o, d);
    }
    return q;
}

// The entry point of the next cell after a zero-length segment with entry point q: unchanged
// but on the crossed axes, where it is on the face it came through (6.6 carries 1 - exit).
vec3 carried(bvec3 crossed, vec3 q, vec3 d) {
    for (int a = 0; a < 3; a++) {
        if (crossed[a]) q[a] = entry_face(a, d);
    }
    return q;
}

// 6.6 Steps every axis of `crossed` into the next cell and its next plane; false when that
// leaves the grid.
bool step_cells(bvec3 crossed, inout ivec3 cell, inout vec3 tmax, vec3 o, vec3 d) {
    ivec3 ncell = P.dims - 1;
    bool left_box = false;
    for (int a = 0; a < 3; a++) {
        if (crossed[a]) {
            cell[a] += d[a] > 0.0 ? 1 : -1;
            left_box = left_box || cell[a] < 0 || cell[a] > ncell[a] - 1;
            tmax[a] = tmax_of(a, cell[a], o, d);
        }
    }
    return !left_box;
}

// 6.3–6.5 in one owned cell: the cubic of the segment (its c0 is each surface's g_in), split
// at the roots of its derivative, a crossing wherever the inside predicate changes between
// consecutive split points. Counts them into `crossings`; returns the surfaces whose shown
// crossing is in this cell (bit k; none once `found`), with their brackets.
uint cell_crossings(Corners corners, vec3 q_in, vec3 q_out, float f_in, float f_out, float t_in,
                    float t_out, bool found, inout uint crossings, inout uint exact_mask,
                    inout vec4 brackets[SURFACES]) {
    bool below = P.inside_sign > 0.0;
    uint surfaces = SURFACE_COUNT;
    bool several = surfaces > 1u;
    uint wanted = max(P.crossing, 1u);  // 1 with several surfaces (scene validation)
    bool count_all = P.count_crossings != 0u;
    vec4 shape = cubic_along(corners, q_in, q_out, 0.0);
    float r0, r1;
    int nd = derivative_roots(shape, r0, r1);
    uint cell_mask = 0u;
    for (uint k = 0u; k < surfaces; k++) {
        float iso = threshold(k);
        if (P.skip != 0u && cell_is_clear(corners, iso)) continue;
        float g_in = f_in - iso;
        float g_out = f_out - iso;
        vec4 cubic = vec4(g_in, shape.yzw);
        float su[4];
        float sg[4];
        su[0] = 0.0;
        sg[0] = g_in;
        su[1] = r0;
        sg[1] = cubic_eval(cubic, r0);
        su[2] = r1;
        sg[2] = cubic_eval(cubic, r1);
        su[nd + 1] = 1.0;
        sg[nd + 1] = g_out;

        // 6.5 Crossings, piece by piece.
        for (int s = 0; s <= nd; s++) {
            float ua = su[s], ga = sg[s], ub = su[s + 1], gb = sg[s + 1];
            bool pa = inside_g(below, ga);
            bool pb = inside_g(below, gb);
            if (pa == pb) continue;
            // A point exactly on the surface closes the bracket: the crossing is there.
            bool exact = ga == 0.0 || gb == 0.0;
            float ue = ga == 0.0 ? ua : ub;
            // A crossing at t = 0 (the ray starts on the surface) is not counted.
            if (exact && segment_t(t_in, t_out, ue) <= 0.0) continue;
            crossings++;
            // The shown crossing: the wanted one of the one surface, or each surface's
            // first in the first cell where any crosses.
            bool shown = several ? (cell_mask & (1u << k)) == 0u : crossings == wanted;
            if (found || !shown) continue;
            cell_mask |= 1u << k;
            if (exact) {
                exact_mask |= 1u << k;
                brackets[k] = vec4(ue, ue, 0.0, 0.0);
            } else {
                brackets[k] = vec4(ua, ub, ga, gb);
            }
            if (!count_all) break;
        }
    }
    return cell_mask;
}

#ifdef OCCUPANCY
// 6a with the occupancy structure (whole grids, skipping on): from `cell`, to the next cell that
// may hold a crossing (true, its corners in `corners`) or the end of the walk (false), updating
// the walk's state as it goes. An empty brick's distance r makes the cube of (2r - 1)^3 bricks
// around it, all empty, one jump (counted one pass), landing where the cell-by-cell walk is
// when it leaves the cube (leave_cells); a cell of a brick that may hold a surface is a
// candidate when its bit in the brick's mask is set, which is the plain walk's test on the same
// corners, so the corners of the cells stepped over are never read, and a 2^3 or 4^3 block of
// the brick with no candidate is one jump too. Both passes of the two-pass walk run it (the
// first up to the first candidate).
bool occupancy_next(inout ivec3 cell, inout vec3 tmax, inout float t_in, inout bvec3 entered,
                    inout bool known, inout vec3 q_known, inout uint passes, uint max_passes,
                    float t_hi, vec3 o, vec3 d, bool may_jump, out Corners corners) {
    // One loop, whose every pass either jumps or steps one cell: llvmpipe runs the whole
    // body of a loop on every iteration whichever branch the lanes take, so a jump and a
    // cell share one body rather than each having a loop of its own.
    ivec3 nb = brick_counts();
    while (passes < max_passes) {
        ivec3 b = cell / BRICK;
        int brick = (b.z * nb.y + b.y) * nb.x + b.x;
        uint reach = reaches[brick];
        bool jump = reach != 0u && may_jump && min(tmax.x, min(tmax.y, tmax.z)) > t_in;
        passes++;
        // What to leave in a jump: the cube of empty bricks around this one, or the cell's
        // 4^3 or 2^3 block when none of its cells is a candidate.
        int h = int(reach) - 1;
        ivec3 first = (b - h) * BRICK;
        int size = (2 * h + 1) * BRICK;
        if (reach == 0u) {
            ivec3 l = cell - b * BRICK;
            uint m = mask_bit(l);
            uint at = uint(brick * MASK_WORDS) + (m >> 5u);
            uint word = masks[at];
            if ((word & (1u << (m & 31u))) != 0u) {
                corners = cell_corners(cell);
                return true;
            }
            // The 2^3 block is 8 bits of this word, the 4^3 block this word and its pair.
            size = ((word >> (m & 24u)) & 0xffu) == 0u ? 2 : 1;
            if (word == 0u && masks[at ^ 1u] == 0u) size = 4;
            first = cell & ~(size - 1);  // blocks are aligned, bricks too
            jump = size > 1 && may_jump && min(tmax.x, min(tmax.y, tmax.z)) > t_in;
        }
        // To the end of this cell's segment, or of the block it leaves.
        float t_b = jump ? leave_cells(cell, tmax, t_hi, o, d, block_last(first, size, cell, d))
                         : segment_end(tmax, t_in, t_hi);
        if (t_b >= t_hi) return false;
        entered = lessThanEqual(tmax, vec3(t_b));
        known = !jump && known && t_b == t_in;  // a jump has t_b > t_in
        if (known) q_known = carried(entered, q_known, d);
        if (!step_cells(entered, cell, tmax, o, d)) return false;
        t_in = t_b;
    }
    return false;
}
#endif

// Whether this process traces `cell` (P.block_lo .. P.block_hi: the whole grid, or an MPI
// rank's block). Cells outside are walked (so `steps`, the brick jumps and the t of every
// plane are the whole walk's) but not evaluated: their values are on another rank.
//
// With the brick pool (GRID_POOL) a cell is also owned only when its brick is in the pool: the
// bricks left out are those brick_is_empty calls empty, which hold no crossing at all (not even
// one of rounding: the margin), so walking them without evaluating gives the whole walk's
// crossings, `steps` and carried values (re-evaluated on entering a resident cell, as between
// blocks), and the image is bit for bit the one of the whole grid, skipping on or off.
bool owned(ivec3 cell) {
    bool in_block =
        all(greaterThanEqual(cell, P.block_lo)) && all(lessThan(cell, P.block_hi));
#ifdef GRID_POOL
    return in_block && resident(cell);
#else
    return in_block;
#endif
}

void main() {
#ifdef OCC_RESUME
    uint at = gl_WorkGroupID.x * uint(RAY_GROUP * RAY_GROUP) + gl_LocalInvocationIndex;
    if (at >= count) return;
    uvec4 state0 = listed[2u * at];
    uvec4 state1 = listed[2u * at + 1u];
    uvec2 px_local = uvec2(state0.x % P.picture_width, state0.x / P.picture_width);
#else
    uvec2 px_local = gl_GlobalInvocationID.xy;
    if (px_local.x >= P.picture_width || px_local.y >= band.rows) return;
#endif
    uvec2 px = uvec2(px_local.x, px_local.y + band.row_offset) * P.stride;
    vec3 eye;  // the ray's origin: the eye, or its pixel on the orthographic image plane
    vec3 dir;
    camera_ray(px, eye, dir);
    float INF = uintBitsToFloat(0x7f800000u);

    Pixel r;
    r.rgba = P.background;
    r.normal = vec3(0.0);
    r.depth = INF;
    r.position = vec3(0.0);
    r.steps = 0.0;
    r.cell = ivec3(-1);
    r.crossings = P.count_crossings != 0u ? 0 : -1;  // -1: not counted (render.count_crossings)
    r.surface = -1;
    r.value = uintBitsToFloat(0x7fc00000u);  // NaN: no [color] value
    r.pad0 = 0u;
    r.pad1 = 0u;

    bool below = P.inside_sign > 0.0;
    uint surfaces = SURFACE_COUNT;
    bool several = surfaces > 1u;
    uint wanted = max(P.crossing, 1u);  // 1 with several surfaces (scene validation)
    bool count_all = P.count_crossings != 0u;

    // 1. Index space (the eye's index-space position comes from the CPU, in f64; an
    // orthographic ray's origin is offset from it in the image plane).
    ivec3 ncell = P.dims - 1;
    vec3 n = vec3(ncell);
    vec3 o = P.eye_grid;
    if (camera_orthographic()) o += pixel_offset(px) * P.inv_spacing;
    vec3 d = dir * P.inv_spacing;
    bool usable = !any(isnan(o)) && !any(isinf(o)) && !any(isnan(d)) && !any(isinf(d))
        && d != vec3(0.0);

    // 2. Slab clip.
    float t_enter = -INF;
    float t_exit = INF;
    int enter_axis = -1;
    for (int a = 0; a < 3 && usable; a++) {
        if (d[a] == 0.0) {
            if (!(o[a] >= 0.0 && o[a] <= n[a])) usable = false;
            continue;
        }
        float t0 = (0.0 - o[a]) / d[a];
        float t1 = (n[a] - o[a]) / d[a];
        float near = d[a] > 0.0 ? t0 : t1;
        float far = d[a] > 0.0 ? t1 : t0;
        if (near > t_enter) {
            t_enter = near;
            enter_axis = a;
        }
        if (far < t_exit) t_exit = far;
    }
    // 2b. Clip planes (the same t along the grid-frame world ray): a later entry enters
    // through a plane, not a box face.
    float c_lo = -INF;
    float c_hi = INF;
    if (usable && !clip_interval(eye, dir, c_lo, c_hi)) usable = false;
    if (c_lo > t_enter) {
        t_enter = c_lo;
        enter_axis = -1;
    }
    t_exit = min(t_exit, c_hi);
    if (!usable || !(t_enter <= t_exit && t_exit > 0.0 && t_exit < INF)) {
        pixels[px_local.y * P.picture_width + px_local.x] = r;
        return;
    }
    float t_lo = max(t_enter, 0.0);
    float t_hi = t_exit;

    // 3. Entry point: exactly on the entry face when the ray enters through it.
    vec3 p = o + t_lo * d;
    if (t_lo == t_enter && enter_axis >= 0) {
        p[enter_axis] = d[enter_axis] > 0.0 ? 0.0 : n[enter_axis];
    }
    p = clamp(p, vec3(0.0), n);

    // 4. First cell: a ray starting on a grid plane goes into the cell it heads into.
    ivec3 cell;
    vec3 q_in;
    for (int a = 0; a < 3; a++) {
        float c = d[a] < 0.0 ? ceil(p[a]) - 1.0 : floor(p[a]);
        c = clamp(c, 0.0, n[a] - 1.0);
        cell[a] = int(c);
        q_in[a] = clamp(p[a] - c, 0.0, 1.0);
    }
    Corners corners;

    // 5. Next planes, from plane indices.
    vec3 tmax = vec3(tmax_of(0, cell.x, o, d), tmax_of(1, cell.y, o, d), tmax_of(2, cell.z, o, d));
    float t_in = t_lo;

    // Jumps need tmax strictly increasing along each axis (so the cell-by-cell walk has no
    // zero-length segments inside a brick): plane numerators c - o distinct and ordered
    // (|o| < 2^20), quotients finite and normal (2^-90 < |d| < 2^90). Always true for cameras within a million cells
    // of the grid; other rays walk cell by cell.
    bool may_jump = P.skip != 0u && all(lessThan(abs(o), vec3(1048576.0)));
    for (int a = 0; a < 3; a++) {
        float m = abs(d[a]);
        if (m != 0.0 && !(m > 8.0779356694631609e-28 && m < 1.2379400392853803e27)) may_jump = false;
    }

    // 6. The walk.
    uint max_passes = uint(ncell.x + ncell.y + ncell.z);
    uint passes = 0u;
#ifdef OCC_SKIP
    // The walk's first passes, up to its first candidate cell (occupancy_next, as the walk
    // below): the cell walk without the cubic's code, which the second pass runs only for the
    // rays that reach a candidate.
    {
        bvec3 entered = bvec3(false);
        bool known = true;
        vec3 q_known = q_in;
        Corners unused;
        bool ended = !occupancy_next(cell, tmax, t_in, entered, known, q_known, passes,
                                     max_passes, t_hi, o, d, may_jump, unused);
        // The second pass counts the candidate's pass again, and starts from the ray's start
        // when every segment so far had length 0 (its entry point is then step 4's, carried).
        bool jumped = !known;
        uint listed_passes = jumped ? passes - 1u : 0u;
        uint pix = px_local.y * P.picture_width + px_local.x;
        if (ended) {
            // The walk ends here, with no crossing: the miss record.
            r.steps = float(passes);
            pixels[pix] = r;
        }
        // Listed: one atomic per subgroup for its listed lanes, and one more workgroup of the
        // resuming pass for each RAY_GROUP^2 rays listed.
        uvec4 ballot = subgroupBallot(!ended);
        uint n = subgroupBallotBitCount(ballot);
        uint first = 0u;
        if (subgroupElect() && n > 0u) {
            first = atomicAdd(count, n);
            uint per = uint(RAY_GROUP * RAY_GROUP);
            uint more = (first + n + per - 1u) / per - (first + per - 1u) / per;
            if (more > 0u) atomicAdd(groups_x, more);
        }
        first = subgroupBroadcastFirst(first);
        if (!ended) {
            uint k = first + subgroupBallotExclusiveBitCount(ballot);
            uint bits = (entered.x ? 1u : 0u) | (entered.y ? 2u : 0u) | (entered.z ? 4u : 0u)
                | (jumped ? 8u : 0u);
            listed[2u * k] = uvec4(pix, uvec3(cell));
            listed[2u * k + 1u] = uvec4(floatBitsToUint(t_in), listed_passes, bits, 0u);
        }
        return;
    }
#endif
    uint crossings = 0u;
    bool found = false;
    uint visited = 0u;
    // The hit cell's segment and, per surface with a crossing there, its bracket (ua, ub, ga,
    // gb); refined after the walk.
    ivec3 hit_cell = ivec3(0);
    vec3 hit_q_in = vec3(0.0), hit_q_out = vec3(0.0);
    float hit_t_in = 0.0, hit_t_out = 0.0, hit_f_in = 0.0;
    uint hit_mask = 0u;   // bit k: surface k crosses in the hit cell
    uint exact_mask = 0u; // bit k: ... exactly at a split point (ua)
    vec4 brackets[SURFACES];

    // The walk is nested loops: the inner ones only find the next cell that may hold a crossing
    // (6a: jumping over empty bricks, stepping over clear cells), the outer one evaluates that
    // cell (6b), once per such cell. llvmpipe runs every branch of a loop body under a mask on
    // each iteration, so the cubic out of the inner loops costs per candidate cell, not per cell
    // walked. Without skipping every owned cell is a candidate: the reference's walk.
    //
    // A candidate is evaluated from its own corners and entry point, which are the bits a walk
    // carrying them from cell to cell would have: the value at a face point is the same from
    // both cells sharing the face (interp_value), and the entry point is the previous exit point,
    // computed from the t the cell is entered at, except while every segment so far had length
    // 0 (a ray starting on a plane), when it is carried from step 4's (`known`).
    bool skip = P.skip != 0u;
    bool known = true;        // q_in is `q_known` (step 4's, carried through zero-length cells)
    vec3 q_known = q_in;
    bvec3 entered = bvec3(false);  // the axes whose planes the walk crossed into `cell`
#ifdef OCC_RESUME
    // From where the first pass left the walk: after its jumps, in the state they reached.
    passes = state1.y;
    if ((state1.z & 8u) != 0u) {
        cell = ivec3(state0.yzw);
        tmax = vec3(tmax_of(0, cell.x, o, d), tmax_of(1, cell.y, o, d), tmax_of(2, cell.z, o, d));
        t_in = uintBitsToFloat(state1.x);
        entered = bvec3((state1.z & 1u) != 0u, (state1.z & 2u) != 0u, (state1.z & 4u) != 0u);
        known = false;
    }
#endif
    for (;;) {
        // 6a. To the next cell that may hold a crossing: cells one by one, and before each,
        // the empty bricks from there in jumps (a loop of its own: a jump reads one brick's
        // range, a cell its 8 corners, and llvmpipe pays for every read in a loop body on
        // every iteration).
        bool candidate = false;
        bool ended = false;
#ifdef OCCUPANCY
        // The same walk with the occupancy structure (occupancy_next): the same cells are
        // evaluated from the same entry points, so the image is the plain walk's, bit for bit;
        // `steps` counts the cells and jumps this walk makes.
        candidate = occupancy_next(cell, tmax, t_in, entered, known, q_known, passes, max_passes,
                                   t_hi, o, d, may_jump, corners);
#else
        while (passes < max_passes) {
            bool empty = false;
            while (passes < max_passes) {
                empty = skip && brick_is_empty(cell);
                if (!(empty && may_jump && min(tmax.x, min(tmax.y, tmax.z)) > t_in)) break;
                // Its whole superbrick at once when that is empty too (then so is each of its
                // bricks: range_is_empty), counted as the jumps through its bricks.
                bool whole = BRICK_LEVELS > 1 && superbrick_is_empty(cell);
                passes += whole ? brick_jumps(cell, t_hi, o, d) : 1u;
                float t_b = leave_brick(cell, tmax, t_hi, o, d, whole);
                // The rest of the ray lies in this brick: no crossing is left.
                ended = t_b >= t_hi;
                if (ended) break;
                entered = lessThanEqual(tmax, vec3(t_b));
                known = false;  // t_b > t_in
                ended = !step_cells(entered, cell, tmax, o, d);
                if (ended) break;
                t_in = t_b;
            }
            if (ended || passes >= max_passes) break;
            passes++;
            if (!empty && owned(cell)) {
                corners = cell_corners(cell);
                // A missing cell (field.glsl) holds no crossing: stepped over like a clear one.
                if (!cell_missing(corners) && (!skip || !cell_all_clear(corners))) {
                    candidate = true;
                    break;
                }
            }
            // A cell with no crossing (a cell of an empty brick that cannot be jumped, a clear
            // or missing cell or another block's): step over it, as 6.6 does.
            float t_b = segment_end(tmax, t_in, t_hi);
            if (t_b >= t_hi) break;
            entered = lessThanEqual(tmax, vec3(t_b));
            known = known && t_b == t_in;
            if (known) q_known = carried(entered, q_known, d);
            if (!step_cells(entered, cell, tmax, o, d)) break;
            t_in = t_b;
        }
#endif
        if (!candidate) break;

        // 6b. The candidate cell.
        q_in = known ? q_known : entry_point(entered, cell, t_in, o, d);
        float f_in = interp_value(corners, q_in);
        float t_out = segment_end(tmax, t_in, t_hi);
        bvec3 crossed = lessThanEqual(tmax, vec3(t_out));
        vec3 q_out = exit_point(crossed, cell, q_in, t_in, t_out, o, d);
        float f_out = t_out == t_in ? f_in : interp_value(corners, q_out);
        uint cell_mask = cell_crossings(corners, q_in, q_out, f_in, f_out, t_in, t_out, found,
                                        crossings, exact_mask, brackets);
        if (!found && cell_mask != 0u) {
            // 7. The hit is in this cell: keep where it is; refined after the walk.
            found = true;
            visited = passes;
            hit_mask = cell_mask;
            hit_cell = cell;
            hit_q_in = q_in;
            hit_q_out = q_out;
            hit_t_in = t_in;
            hit_t_out = t_out;
            hit_f_in = f_in;
        }
        // Nothing after the hit changes the image unless every crossing is counted.
        if (found && !count_all) break;

        // 6.6 Advance: step every crossed axis (ties step together: diagonal through an edge
        // or corner).
        if (t_out >= t_hi) break;
        entered = crossed;
        known = known && t_out == t_in;
        if (known) q_known = carried(entered, q_in, d);
        if (!step_cells(crossed, cell, tmax, o, d)) break;
        t_in = t_out;
    }

    // 7. The hit: each surface crossing in the hit cell refined, the nearest kept (ties: the
    // lower surface), then its attributes. Out of the loop on purpose: llvmpipe runs a
    // branch's code for every lane under a mask, so code in the walk's body costs on every
    // cell of every ray.
    if (found) {
        Corners k8 = cell_corners(hit_cell);
        vec4 shape = cubic_along(k8, hit_q_in, hit_q_out, 0.0);
        float hit_t = INF;
        float hit_u = 0.0;
        uint hit_surface = 0u;
        for (uint k = 0u; k < surfaces; k++) {
            if ((hit_mask & (1u << k)) == 0u) continue;
            vec4 b = brackets[k];
            vec4 cubic = vec4(hit_f_in - threshold(k), shape.yzw);
            float u = (exact_mask & (1u << k)) != 0u
                ? b.x : refine_root(cubic, below, b.x, b.y, b.z, b.w, P.newton_steps);
            float t = segment_t(hit_t_in, hit_t_out, u);
            if (t < hit_t) {
                hit_t = t;
                hit_u = u;
                hit_surface = k;
            }
        }
        vec3 hit_q = vec3(lerp1(hit_q_in.x, hit_q_out.x, hit_u),
                          lerp1(hit_q_in.y, hit_q_out.y, hit_u),
                          lerp1(hit_q_in.z, hit_q_out.z, hit_u));
        vec3 grad = interp_gradient(k8, hit_q) * P.inv_spacing;
        vec3 oriented = below ? grad : -grad;
        r.normal = unit_or(oriented, -dir);
        r.normal = scene_normal(vec3(hit_cell) + hit_q, hit_cell, r.normal);
        r.depth = hit_t;
        r.position = eye + hit_t * dir;
        r.cell = hit_cell;
        r.surface = several ? int(hit_surface) : -1;
        r.rgba = vec4(shade(r.normal, dir, hit_t, float(visited), vec3(hit_cell) + hit_q,
                            hit_cell, P.surface_color[hit_surface].rgb), 1.0);
    }
    r.steps = float(found ? visited : passes);
    r.crossings = count_all ? int(crossings) : -1;
    pixels[px_local.y * P.picture_width + px_local.x] = r;
}
