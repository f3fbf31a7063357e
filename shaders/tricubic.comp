#version 450
// Exact ray tracing of the tricubic interpolants' surface (`render.method = "analytic"` with
// `field.interpolation = "cubic-bspline" | "catmull-rom"`; the variants that define
// INTERP_BSPLINE or INTERP_CATMULL_ROM, build.rs): the cell walk of `reference::analytic` over
// its tricubic RayCell (`reference::analytic::tricubic`, `bernstein`), whose module docs are
// the specification, in f32 step for step:
//   1-5. index space, slab and clip-plane clip, entry point (walk.glsl), first cell, next
//        planes: as trilinear's walk (analytic.comp);
//   6.   per cell: its 4x4x4 samples (the edge clamp), the segment's field as a degree-9
//        Bernstein polynomial from the weights' blossoms (`cubic_segment`), its ends replaced
//        by the walk's face values, so neighbouring cells decide on the same values; the
//        isolation's leaves in u order (stackless: each node restricted from the root,
//        depth BERNSTEIN_DEPTH, BERNSTEIN_NODES nodes); a leaf whose end predicates differ
//        holds one crossing, exactly at an end that is 0, else refined by Newton on the
//        leaf's own coefficients, safeguarded by its bracket;
//   7.   the hit: the wanted crossing; normal the interpolant's exact gradient there.
// Several surfaces share the walk: each cell's polynomial is the field's, minus each
// surface's isovalue; the first crossing of any surface is the hit (ties: the lower surface),
// the reference's nearest-hit rule over surfaces traced alone.
//
// Empty-space skipping (`P.skip`), analytic.comp's, with the interpolant's own min/max grid
// (`bricks[]`, `passes::bricks::Bound`): a brick's range is over the points its cells' 4x4x4
// stencils read, which bounds the B-spline (its values and every Bernstein coefficient of a
// segment are convex combinations of them); Catmull-Rom's is widened by 37/54 of its width on
// each side (its overshoot bound, `field::interpolant::cubic`'s "Bounds"). Every value the walk
// decides a predicate on in a cell (face values, leaf ends: de Casteljau averages of the
// coefficients) is then within the range up to f32 rounding, which SKIP_MARGIN covers
// (bricks.glsl). The walk jumps over a clearly empty brick (or superbrick) to the cell and t
// the cell-by-cell walk reaches (`leave_brick`), steps over a cell whose fine brick (FINE^3
// cells, the grid's finer level with the same bound) is clear without reading its samples,
// and runs no isolation in a cell whose own samples' range (widened the same way) is clear
// (its segment is formed: skipping that in a loop of its own measured slower); a candidate cell is
// evaluated from its own samples and entry point, which are the bits the carried ones have
// (face exactness: `cubic`'s module doc; the entry point is analytic.comp's `entry_point`).
// So every channel is bit for bit the walk without skipping, but `steps`: cells tested plus one
// per brick jumped (a superbrick jump counts the bricks it crosses), as the reference counts
// them with `render.skip` (`reference::skipping`).

#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

// The loops over a cell's 64 samples (field.glsl's cell_samples and samples_missing,
// cell_is_clear) unrolled, so that every index into `Samples` is a constant. With a loop index
// (64 iterations: not unrolled) the array is indexed at run time, which costs llvmpipe about a
// third of the gyroid's render, and its results depended on the neighbouring lanes where the
// samples were read under divergent control flow (in 6a's loop: rays lost crossings, the
// lane-dependence docs/limitations.md recorded); the same code with these loops unrolled is
// bit for bit the walk without skipping (the_other_walks_skip_bit_identically).
#define CUBIC_UNROLL [[unroll]]

layout(local_size_x = RAY_GROUP, local_size_y = RAY_GROUP) in;  // build.rs

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
#ifdef GRID_BUFFER
// The whole grid's points, x fastest (render/mod.rs's copy of the image; field.glsl reads it).
layout(std430, binding = 1) readonly buffer Grid { float grid[]; };
#else
layout(binding = 1) uniform sampler3D u_grid;
#endif
// Read too: a resumed ray that had its hit before it was cut short finds the hit's record here.
layout(std430, binding = 2) buffer Out { Pixel pixels[]; };
layout(std430, binding = 3) readonly buffer Colormap { vec4 colormap[256]; };
layout(std430, binding = 4) readonly buffer Bricks { vec2 bricks[]; };
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;

// Walks cut short (passes/tricubic.rs, `occupancy::Listed`). llvmpipe ends every loop of an
// invocation once its loops have passed 65,535 back-edges in all, counted for its whole group of
// 8 lanes (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS; raymarch.comp's LONG_MARCH): a walk through
// thousands of candidate cells (a noisy volume, `count_crossings`, a late `crossing`) stopped
// there silently and lost what lay beyond. The walk therefore keeps, at the top of each of its
// iterations, the state it had there (a checkpoint: clean, since loops still ran), and learns
// whether the cap ended its loops: it did if the walk left its loop without ending (the cap
// ends the loop), or if a probe loop of two passes, run where the walk ends, made only one. A
// walk cut short lists its pixel and checkpoint; the resuming build of this shader (RESUMED),
// dispatched over the listed rays (indirectly), goes on from there, in place, round after round
// until no ray is left (`live`). Every channel is the uncut walk's, bit for bit: the walk from
// a checkpoint is the same walk. A round that cannot finish one iteration of a ray's walk
// counts it in `lost` (the renderer refuses the picture) instead of listing it for ever.
// A listed ray: (pixel, cell.xyz), (t_in bits, passes, crossings, flags).
layout(std430, binding = 5) buffer Listed { uvec4 listed[]; };
layout(std430, binding = 6) buffer Count {
    uint count;     // rays listed (by the first round)
    uint groups_x;  // the resuming rounds' workgroups (VkDispatchIndirectCommand)
    uint groups_y;
    uint groups_z;
    uint live;      // rays this round cut short again (zeroed before each round)
    uint lost;      // rays whose walk made no progress in a round
    uint probe;     // 2: the probe loop's trip count, read from memory so no compiler unrolls it
};
// The build that goes on from listed checkpoints (specialization constant 2).
layout(constant_id = 2) const bool RESUMED = false;
// A listed ray's flags: the axes entered (bits 0-2), then these.
const uint LISTED_HIT = 8u;    // its hit is found (and its record written: count_crossings)
const uint LISTED_LIVE = 16u;  // its walk goes on in the next round
const uint LISTED_KNOWN = 32u; // a checkpoint's entry point is step 4's (never listed)

// The build without a variant macro is the B-spline's (build.rs compiles every .comp as it is).
#if !defined(INTERP_BSPLINE) && !defined(INTERP_CATMULL_ROM)
#define INTERP_BSPLINE 1
#endif
#include "field.glsl"
#include "shade.glsl"
#include "camera.glsl"
#include "clip.glsl"
#include "walk.glsl"
#include "bricks.glsl"

const int DEG = 9;
// C(3, j) and C(9, j): the scaled Bernstein form's factors (`bernstein::Scaled`).
const float BIN3[4] = float[4](1.0, 3.0, 3.0, 1.0);
const float BIN9[10] = float[10](1.0, 9.0, 36.0, 84.0, 126.0, 126.0, 84.0, 36.0, 9.0, 1.0);
// A Newton step this small that leaves the bracket is rounding (`cubic::CONVERGED`, in f32).
const float CONVERGED = 4.0 * 1.1920929e-7;

struct Poly {
    float b[10];
};

// The blossom of weight `row` at (t1, t2, t3) (`cubic::blossom`).
float blossom(int row, float t1, float t2, float t3) {
    vec4 n = CUBIC_NUM[row];
    float s1 = t1 + t2 + t3;
    float s2 = t1 * t2 + t1 * t3 + t2 * t3;
    float s3 = t1 * t2 * t3;
    return (n.x + n.y * s1 / 3.0 + n.z * s2 / 3.0 + n.w * s3) / CUBIC_DEN;
}

// The 4 weights' Bernstein coefficients along one axis's segment t0 -> t1: w[a][j] is weight
// a's coefficient j, the blossom at (t0^(3-j), t1^j) (`tricubic::weight_blossoms`).
void weight_blossoms(float t0, float t1, out vec4 w[4]) {
    for (int a = 0; a < 4; a++) {
        w[a] = vec4(blossom(a, t0, t0, t0), blossom(a, t0, t0, t1), blossom(a, t0, t1, t1),
                    blossom(a, t1, t1, t1));
    }
}

// The field along the segment q_in -> q_out in Bernstein form, degree 9, without the
// isovalue or the face values (`tricubic::segment` before its step 3).
Poly cubic_segment(Samples k, vec3 q_in, vec3 q_out) {
    vec4 bx[4];
    vec4 by[4];
    vec4 bz[4];
    weight_blossoms(q_in.x, q_out.x, bx);
    weight_blossoms(q_in.y, q_out.y, by);
    weight_blossoms(q_in.z, q_out.z, bz);
    float f[10];
    for (int i = 0; i < 10; i++) f[i] = 0.0;
    for (int c = 0; c < 4; c++) {
        float q[7];
        for (int i = 0; i < 7; i++) q[i] = 0.0;
        for (int b = 0; b < 4; b++) {
            int r = 4 * b + 16 * c;
            float pi[4];
            for (int j = 0; j < 4; j++) {
                pi[j] = ((k.s[r] * bx[0][j] + k.s[r + 1] * bx[1][j]) + k.s[r + 2] * bx[2][j])
                        + k.s[r + 3] * bx[3][j];
            }
            for (int i = 0; i < 4; i++) {
                for (int j = 0; j < 4; j++) {
                    q[i + j] += (BIN3[i] * pi[i]) * (BIN3[j] * by[b][j]);
                }
            }
        }
        for (int i = 0; i < 7; i++) {
            for (int j = 0; j < 4; j++) {
                f[i + j] += q[i] * (BIN3[j] * bz[c][j]);
            }
        }
    }
    Poly p;
    for (int i = 0; i < 10; i++) p.b[i] = f[i] / BIN9[i];
    return p;
}

// The half [0, 1/2] (left) or [1/2, 1] of a polynomial, by de Casteljau at 1/2
// (`Bernstein::keep_left`, `keep_right`).
// Both loops unrolled, the inner one over a constant range with the triangle's bound as a
// condition (a bound that depends on r keeps the driver from unrolling either): as loops,
// their back-edges counted towards llvmpipe's cap (raymarch.comp's LONG_MARCH) on every node.
void keep_left(inout Poly c) {
    [[unroll]] for (int r = 1; r <= DEG; r++) {
        [[unroll]] for (int i = DEG; i >= 1; i--) {
            if (i >= r) c.b[i] = 0.5 * (c.b[i - 1] + c.b[i]);
        }
    }
}

void keep_right(inout Poly c) {
    [[unroll]] for (int r = 1; r <= DEG; r++) {
        [[unroll]] for (int i = 0; i < DEG; i++) {
            if (i <= DEG - r) c.b[i] = 0.5 * (c.b[i] + c.b[i + 1]);
        }
    }
}

// The root restricted to [k 2^-level, (k + 1) 2^-level] (`Bernstein::restrict`).
Poly restrict_to(Poly root, uint level, uint k) {
    Poly c = root;
    for (uint i = level; i > 0u; i--) {
        if (((k >> (i - 1u)) & 1u) == 0u) {
            keep_left(c);
        } else {
            keep_right(c);
        }
    }
    return c;
}

// Sign changes of the coefficients, zeros skipped (`Bernstein::variations`).
uint variations(Poly c) {
    uint v = 0u;
    int last = 0;
    for (int i = 0; i <= DEG; i++) {
        int s = c.b[i] > 0.0 ? 1 : (c.b[i] < 0.0 ? -1 : 0);
        if (s != 0) {
            if (last != 0 && s != last) v++;
            last = s;
        }
    }
    return v;
}

// Whether Descartes' rule settles the node (`Bernstein::resolved`).
bool resolved(Poly c, uint v) {
    float first = c.b[0], last = c.b[DEG];
    if (v == 0u) {
        bool all_zero = true;
        for (int i = 0; i <= DEG; i++) all_zero = all_zero && c.b[i] == 0.0;
        return first != 0.0 || last != 0.0 || all_zero;
    }
    if (v == 1u) return first != 0.0 && last != 0.0;
    return false;
}

// The value and derivative at s in [0, 1] (`Bernstein::eval_with_derivative`).
vec2 eval_with_derivative(Poly c, float s) {
    float t = 1.0 - s;
    float p[10] = c.b;
    for (int r = 1; r < DEG; r++) {
        for (int i = 0; i <= DEG - r; i++) p[i] = t * p[i] + s * p[i + 1];
    }
    return vec2(t * p[0] + s * p[1], float(DEG) * (p[1] - p[0]));
}

bool inside_g(float g) {
    return P.inside_sign > 0.0 ? g < 0.0 : g > 0.0;
}

// The root of the leaf c (ends g_lo, g_hi nonzero, predicates different) in its own [0, 1]:
// the secant start, then `steps` Newton steps safeguarded by the bracket (`cubic::refine_with`).
float refine_leaf(Poly c, float g_lo, float g_hi, uint steps) {
    float lo = 0.0, hi = 1.0;
    bool p_lo = inside_g(g_lo);
    float u = lo + (hi - lo) * (g_lo / (g_lo - g_hi));
    if (!(u > lo && u < hi)) u = 0.5 * (lo + hi);
    for (uint i = 0u; i < steps; i++) {
        vec2 gd = eval_with_derivative(c, u);
        if (gd.x == 0.0) break;
        if (inside_g(gd.x) == p_lo) {
            lo = u;
        } else {
            hi = u;
        }
        float step = gd.x / gd.y;
        float next = u - step;
        if (!(next > lo && next < hi)) {
            if (abs(step) <= CONVERGED) break;
            next = 0.5 * (lo + hi);
        }
        if (next == u) break;
        u = next;
    }
    return u;
}

// Ray parameter of segment parameter u (`segment_t`): at most t_out, exactly t_out at u = 1.
float segment_t(float t_in, float t_out, float u) {
    return u >= 1.0 ? t_out : min(t_in + u * (t_out - t_in), t_out);
}

// Local coordinate `a` of the ray's point at t in `cell`: the one expression for a cell's exit
// point and the next cell's entry point, so both have the same bits (analytic.comp's).
float local_at(int a, float t, ivec3 cell, vec3 o, vec3 d) {
    return clamp(o[a] + t * d[a] - float(cell[a]), 0.0, 1.0);
}

// Local coordinate `a` of the face a ray crossing planes of axis `a` enters a cell through.
float entry_face(int a, vec3 d) {
    return d[a] > 0.0 ? 0.0 : 1.0;
}

// The local entry point of a cell entered at t_in across the planes of `entered`: what 6.6
// carries from the previous cell's exit point (1 - q on the crossed axes).
vec3 entry_point(bvec3 entered, ivec3 cell, float t_in, vec3 o, vec3 d) {
    vec3 q;
    [[unroll]] for (int a = 0; a < 3; a++) {
        q[a] = entered[a] ? entry_face(a, d) : local_at(a, t_in, cell, o, d);
    }
    return q;
}

// The entry point of the next cell after a zero-length segment with entry point q: unchanged
// but on the crossed axes.
vec3 carried(bvec3 crossed, vec3 q, vec3 d) {
    [[unroll]] for (int a = 0; a < 3; a++) {
        if (crossed[a]) q[a] = entry_face(a, d);
    }
    return q;
}

// 6.6 Steps every axis of `crossed` into the next cell and its next plane; false when that
// leaves the grid.
bool step_cells(bvec3 crossed, inout ivec3 cell, inout vec3 tmax, vec3 o, vec3 d) {
    ivec3 ncell = P.dims - 1;
    bool left_box = false;
    [[unroll]] for (int a = 0; a < 3; a++) {
        if (crossed[a]) {
            cell[a] += d[a] > 0.0 ? 1 : -1;
            left_box = left_box || cell[a] < 0 || cell[a] > ncell[a] - 1;
            tmax[a] = tmax_of(a, cell[a], o, d);
        }
    }
    return !left_box;
}

// Whether no surface can cross in a (non-missing) cell of samples k: their range, widened by
// Catmull-Rom's bound as its bricks' are (bricks.comp), is clear of every isovalue
// (range_is_empty). The candidate's isolation then does not run.
bool cell_is_clear(Samples k) {
    float lo = k.s[0], hi = k.s[0];
    CUBIC_UNROLL for (int n = 1; n < 64; n++) {
        lo = min(lo, k.s[n]);
        hi = max(hi, k.s[n]);
    }
#ifdef INTERP_CATMULL_ROM
    precise float spread = uintBitsToFloat(CATMULL_ROM_KAPPA_BITS) * (hi - lo);
    precise float wlo = lo - spread;
    precise float whi = hi + spread;
    lo = wlo;
    hi = whi;
#endif
    return range_is_empty(vec2(lo, hi));
}

// Whether llvmpipe's loop cap has ended this invocation's loops (Count's comment): a loop of
// `probe` = 2 passes then makes one (past the cap every loop ends after its first pass).
bool loop_cap_reached() {
    uint made = 0u;
    [[dont_unroll]] for (uint i = 0u; i < probe; i++) made++;
    return made < 2u;
}

// The record of a hit: normal, shading and the other channels of record r.
Pixel hit_pixel(Pixel r, vec3 eye, vec3 dir, float t_hit, uint hit_surface, ivec3 hit_cell,
                vec3 hit_q, vec3 hit_grad) {
    vec3 grad = hit_grad * P.inv_spacing * P.inside_sign;
    vec3 normal = unit_or(grad, -dir);
    vec3 u = vec3(hit_cell) + hit_q;
    r.depth = t_hit;
    r.position = eye + dir * t_hit;
    r.normal = normal;
    r.cell = hit_cell;
    r.surface = P.surfaces > 1u ? int(hit_surface) : -1;
    r.rgba = vec4(shade(normal, dir, t_hit, r.steps, u, hit_cell,
                        P.surface_color[hit_surface].rgb), 1.0);
    return r;
}

void main() {
    uvec2 px_local;
    uint at = 0u;  // the listed ray (RESUMED)
    uvec4 from0 = uvec4(0u), from1 = uvec4(0u);
    if (RESUMED) {
        at = gl_WorkGroupID.x * uint(RAY_GROUP * RAY_GROUP) + gl_LocalInvocationIndex;
        if (at >= count) return;
        from0 = listed[2u * at];
        from1 = listed[2u * at + 1u];
        if ((from1.w & LISTED_LIVE) == 0u) return;
        px_local = uvec2(from0.x % P.picture_width, from0.x / P.picture_width);
    } else {
        px_local = gl_GlobalInvocationID.xy;
        if (px_local.x >= P.picture_width || px_local.y >= band.rows) return;
    }
    uint pix = px_local.y * P.picture_width + px_local.x;
    uvec2 px = uvec2(px_local.x, px_local.y + band.row_offset) * P.stride;
    Pixel r = miss_pixel();
    WalkRay w;
    if (!walk_ray(px, w)) {
        pixels[pix] = r;
        return;
    }
    vec3 eye = w.eye, dir = w.dir, o = w.o, d = w.d, n = w.n, p = w.p;
    float t_lo = w.t_lo, t_hi = w.t_hi;
    ivec3 ncell = P.dims - 1;
    uint surfaces = P.surfaces;
    uint wanted = max(P.crossing, 1u);  // 1 with several surfaces (scene validation)
    bool count_all = P.count_crossings != 0u;

    // 4. First cell: a ray starting on a grid plane goes into the cell it heads into.
    ivec3 cell;
    vec3 q_in;
    for (int a = 0; a < 3; a++) {
        float c = d[a] < 0.0 ? ceil(p[a]) - 1.0 : floor(p[a]);
        c = clamp(c, 0.0, n[a] - 1.0);
        cell[a] = int(c);
        q_in[a] = clamp(p[a] - c, 0.0, 1.0);
    }
    Samples k;

    // 5. Next planes.
    vec3 tmax = vec3(tmax_of(0, cell.x, o, d), tmax_of(1, cell.y, o, d), tmax_of(2, cell.z, o, d));
    float t_in = t_lo;

    // Jumps need tmax strictly increasing along each axis (analytic.comp's may_jump).
    bool skip = P.skip != 0u;
    bool may_jump = skip && all(lessThan(abs(o), vec3(1048576.0)));
    for (int a = 0; a < 3; a++) {
        float m = abs(d[a]);
        if (m != 0.0 && !(m > 8.0779356694631609e-28 && m < 1.2379400392853803e27)) may_jump = false;
    }

    // 6. Loop, as analytic.comp's: inner loops find the next cell that may hold a crossing
    // (6a: brick jumps, then cells stepped over), the outer one evaluates it (6b). Without
    // skipping every non-missing cell is a candidate: the reference's walk.
    uint passes = 0u;
    uint crossings = 0u;
    bool hit = false;
    float t_hit = 0.0;
    uint hit_surface = 0u;
    uint hit_steps = 0u;
    ivec3 hit_cell = cell;
    vec3 hit_q = vec3(0.0);
    vec3 hit_grad = vec3(0.0);
    uint max_passes = uint(ncell.x + ncell.y + ncell.z);
    bool known = true;        // q_in is `q_known` (step 4's, carried through zero-length cells)
    vec3 q_known = q_in;
    bvec3 entered = bvec3(false);  // the axes whose planes the walk crossed into `cell`
    // A listed ray goes on from its checkpoint (tmax from its cell, as the walk computes it:
    // the same bits). Its entry point is then never step 4's: a walk is listed only past it.
    bool resumed_hit = false;  // the hit's record is in pixels[] already
    if (RESUMED) {
        cell = ivec3(from0.yzw);
        tmax = vec3(tmax_of(0, cell.x, o, d), tmax_of(1, cell.y, o, d), tmax_of(2, cell.z, o, d));
        t_in = uintBitsToFloat(from1.x);
        passes = from1.y;
        crossings = from1.z;
        entered = bvec3((from1.w & 1u) != 0u, (from1.w & 2u) != 0u, (from1.w & 4u) != 0u);
        known = false;
        resumed_hit = (from1.w & LISTED_HIT) != 0u;
        hit = resumed_hit;
    }
    // The checkpoint (Count's comment), the state at the top of the latest iteration, is kept
    // in memory: in the ray's listed slot (RESUMED) or its pixel's record, which is written
    // only at the end. In variables it came out mixed: the compiler shares a copy's register
    // with the loop's own state where no path it knows of tells them apart, and the cap's way
    // out of the loop is one it does not know of. The hit's own fields need none (a walk goes
    // on past its hit only to count crossings, and they do not change after it).
    bool ended = false;    // the walk ended (not the cap)
    bool capped = false;   // ... but the cap had ended loops first
    // The loop's bound, 2^31, is read from memory: the compiler (NIR, before llvmpipe adds the
    // cap) must then keep a way out of the loop that passes no `break` -- the way the cap takes
    // -- with `ended` false on it. With `for (;;)` it folded `ended` to true after the loop.
    uint most = probe << 30u;
    uint iterations = 0u;
    while (iterations < most) {
        iterations++;
        uint bits = (entered.x ? 1u : 0u) | (entered.y ? 2u : 0u) | (entered.z ? 4u : 0u)
            | (hit ? LISTED_HIT : 0u) | (known ? LISTED_KNOWN : 0u) | LISTED_LIVE;
        if (RESUMED) {
            listed[2u * at] = uvec4(pix, uvec3(cell));
            listed[2u * at + 1u] = uvec4(floatBitsToUint(t_in), passes, crossings, bits);
        } else {
            pixels[pix].cell = cell;
            pixels[pix].depth = t_in;
            pixels[pix].crossings = int(crossings);
            pixels[pix].pad0 = passes;
            pixels[pix].pad1 = bits;
        }
        // 6a. To the next candidate cell.
        bool candidate = false;
        // No `break` in this loop: with one (to leave at a candidate while other lanes step
        // on), llvmpipe ended some rays early once clear cells were stepped over (the
        // 64^3 torus of the_other_walks_skip_bit_identically lost crossings).
        bool stop = false;
        while (!candidate && !stop && passes < max_passes) {
            bool empty = skip && brick_is_empty(cell);
            float t_b = t_in;
            if (empty && may_jump && min(tmax.x, min(tmax.y, tmax.z)) > t_in) {
                // Its whole superbrick at once when that is empty too, counted as the jumps
                // through its bricks.
                bool whole = BRICK_LEVELS > 1 && superbrick_is_empty(cell);
                passes += whole ? brick_jumps(cell, t_hi, o, d) : 1u;
                t_b = leave_brick(cell, tmax, t_hi, o, d, whole);
                known = false;  // t_b > t_in
            } else {
                passes++;
                // A cell of a brick that is not empty: 6b reads it unless its fine brick is
                // clear (one range read, not 64 samples; a missing cell holds no crossing: not
                // evaluated there). Its samples are not read here: carried out of this loop
                // they cost llvmpipe more than they save (2-3x slower on the gyroid).
                candidate = !empty && !(skip && fine_brick_is_empty(cell));
                // A cell with no crossing: step over it, as 6.6 does.
                if (!candidate) {
                    t_b = max(min(min(tmax.x, min(tmax.y, tmax.z)), t_hi), t_in);
                    known = known && t_b == t_in;
                }
            }
            if (!candidate) {
                // The rest of the ray lies in this brick or cell: no crossing is left.
                stop = t_b >= t_hi;
                if (!stop) {
                    entered = lessThanEqual(tmax, vec3(t_b));
                    if (known) q_known = carried(entered, q_known, d);
                    stop = !step_cells(entered, cell, tmax, o, d);
                    t_in = t_b;
                }
            }
        }
        if (!candidate) {
            ended = true;
            capped = loop_cap_reached();
            break;
        }

        // 6b. The candidate cell: 6.1 segment end, 6.2 exit point and values.
        q_in = known ? q_known : entry_point(entered, cell, t_in, o, d);
        k = cell_samples(cell);
        bool missing = samples_missing(k);
        bool clear = skip && !missing && cell_is_clear(k);
        float t_out = max(min(min(tmax.x, min(tmax.y, tmax.z)), t_hi), t_in);
        bvec3 crossed = lessThanEqual(tmax, vec3(t_out));
        vec3 q_out;
        [[unroll]] for (int a = 0; a < 3; a++) {
            if (crossed[a]) {
                q_out[a] = d[a] > 0.0 ? 1.0 : 0.0;
            } else if (t_out == t_in) {
                q_out[a] = q_in[a];
            } else {
                q_out[a] = local_at(a, t_out, cell, o, d);
            }
        }
        if (!missing) {
            float f_in = cubic_value(k, q_in);
            float f_out = t_out == t_in ? f_in : cubic_value(k, q_out);
            // 6.3 The segment's polynomial, once for every surface.
            Poly fseg = cubic_segment(k, q_in, q_out);
            // The first crossing of this cell among the surfaces, for the hit.
            float best_u = 2.0;
            uint best_k = 0u;
            for (uint s = 0u; s < SURFACE_COUNT; s++) {
                float iso = P.thresholds[s / 4u][s % 4u];
                Poly g;
                [[unroll]] for (int i = 0; i <= DEG; i++) g.b[i] = fseg.b[i] - iso;
                g.b[0] = f_in - iso;
                g.b[DEG] = f_out - iso;
                // 6.4 The isolation's leaves in u order; 6.5 crossings, leaf by leaf.
                uint level = 0u, kk = 0u, nodes = 0u;
                // A clear cell has no leaf whose ends differ: its isolation need not run.
                bool done = clear;
                for (uint guard = 0u; guard < BERNSTEIN_NODES + BERNSTEIN_DEPTH && !done; guard++) {
                    Poly c = restrict_to(g, level, kk);
                    nodes++;
                    uint v = variations(c);
                    bool res = resolved(c, v);
                    // No `continue` in this loop: llvmpipe gave wrong crossings with it once the
                    // walk's loops around it jump and step (the_other_walks_skip_bit_identically).
                    bool split = !(res || level == BERNSTEIN_DEPTH || nodes >= BERNSTEIN_NODES);
                    // A leaf: [kk 2^-level, (kk + 1) 2^-level].
                    float w = 1.0 / float(1u << level);
                    float lo = float(kk) * w;
                    float ga = c.b[0], gb = c.b[DEG];
                    bool exact = ga == 0.0 || gb == 0.0;
                    float u_exact = ga == 0.0 ? lo : lo + w;
                    // A change of the predicate across the leaf, but one exactly at t <= 0.
                    bool counted = !split && inside_g(ga) != inside_g(gb)
                        && !(exact && segment_t(t_in, t_out, u_exact) <= 0.0);
                    if (split) {
                        level++;
                        kk *= 2u;
                    } else {
                        while ((kk & 1u) == 1u) {
                            kk >>= 1u;
                            level--;
                        }
                        if (level == 0u) {
                            done = true;
                        } else {
                            kk += 1u;
                        }
                    }
                    if (counted) {
                        crossings++;
                        if (s == 0u && surfaces == 1u) {
                            // One surface: the wanted-th crossing along the ray.
                            if (!hit && crossings == wanted) {
                                float u = exact ? u_exact : lo + w * refine_leaf(c, ga, gb, P.newton_steps);
                                best_u = u;
                                best_k = 0u;
                            }
                        } else if (!hit) {
                            // Several surfaces (wanted = 1): each surface's first crossing here.
                            float u = exact ? u_exact : lo + w * refine_leaf(c, ga, gb, P.newton_steps);
                            if (u < best_u) {
                                best_u = u;
                                best_k = s;
                            }
                            if (!count_all) done = true;
                        }
                    }
                    if (!count_all && best_u <= 1.0 && surfaces == 1u) done = true;
                }
            }
            if (!hit && best_u <= 1.0) {
                hit = true;
                t_hit = segment_t(t_in, t_out, best_u);
                hit_surface = best_k;
                hit_steps = passes;
                hit_cell = cell;
                hit_q = mix(q_in, q_out, best_u);
                hit_grad = cubic_gradient(k, hit_q);
                if (!count_all) {
                    ended = true;
                    capped = loop_cap_reached();
                    break;
                }
            }
        }
        // 6.6 Advance.
        if (t_out >= t_hi || !step_cells(crossed, cell, tmax, o, d)) {
            ended = true;
            capped = loop_cap_reached();
            break;
        }
        entered = crossed;
        known = known && t_out == t_in;
        if (known) q_known = carried(entered, q_in, d);
        t_in = t_out;
    }

    if (!ended || capped) {
        // Cut short: listed from the checkpoint, which must lie past the round's start (its
        // `passes` grows every iteration) and past step 4's entry point (not `known`): else
        // no round could finish this iteration, and the ray is lost.
        uvec4 ck0, ck1;
        if (RESUMED) {
            ck0 = listed[2u * at];
            ck1 = listed[2u * at + 1u];
        } else {
            Pixel c = pixels[pix];
            ck0 = uvec4(pix, uvec3(c.cell));
            ck1 = uvec4(floatBitsToUint(c.depth), c.pad0, uint(c.crossings), c.pad1);
        }
        bool ck_hit = (ck1.w & LISTED_HIT) != 0u;
        if ((ck1.w & LISTED_KNOWN) != 0u || (RESUMED && ck1.y == from1.y)) {
            atomicAdd(lost, 1u);
            if (RESUMED) listed[2u * at + 1u].w = 0u;
            pixels[pix] = r;
            return;
        }
        if (!RESUMED) {
            uint slot = atomicAdd(count, 1u);
            // One more workgroup of the resuming rounds per RAY_GROUP^2 rays listed.
            if (slot % uint(RAY_GROUP * RAY_GROUP) == 0u) atomicAdd(groups_x, 1u);
            listed[2u * slot] = ck0;
            listed[2u * slot + 1u] = ck1;
        }
        atomicAdd(live, 1u);
        // The pixel's record: a hit before the checkpoint's now (its fields did not change
        // since), else the miss's until a round ends the walk.
        if (ck_hit && !resumed_hit) {
            r.steps = float(hit_steps);
            r = hit_pixel(r, eye, dir, t_hit, hit_surface, hit_cell, hit_q, hit_grad);
        }
        if (!resumed_hit) pixels[pix] = r;
        return;
    }
    if (RESUMED) listed[2u * at + 1u].w = 0u;
    if (resumed_hit) {
        // Its hit's record is written: only the crossings (count_crossings) went on.
        pixels[pix].crossings = int(crossings);
        return;
    }
    if (count_all) r.crossings = int(crossings);
    r.steps = float(hit ? hit_steps : passes);
    if (hit) r = hit_pixel(r, eye, dir, t_hit, hit_surface, hit_cell, hit_q, hit_grad);
    pixels[pix] = r;
}
