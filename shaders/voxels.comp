#version 450
// Exact ray tracing of the nearest-point interpolant's surface (`render.method = "analytic"`
// with `field.interpolation = "nearest"`): a voxel walk, the port of `reference::voxels`
// (f64), whose module doc is the specification, step for step. The field is constant on each
// point's voxel ([i - 1/2, i + 1/2] per axis, clipped to the box); a crossing is a change of a
// surface's inside predicate between two consecutive voxels, both finite, at the t of the face
// plane, exactly: no root to refine. The walk tests every surface at each face: the first
// face where some surface reaches the wanted crossing is the hit (ties: the lower surface),
// which is the reference's nearest-hit rule over the surfaces traced one by one.
//
// Empty-space skipping (`P.skip`): voxel bricks, BRICK^3 voxels (points b BRICK .. (b + 1)
// BRICK - 1 per axis, the region [b BRICK - 1/2, (b + 1) BRICK - 1/2] clipped to the box), and
// voxel superbricks of SUPER^3 of them. A voxel brick's values are its points' samples, all
// among the corners of trilinear brick b's cells (b BRICK .. (b + 1) BRICK), so trilinear's
// min/max grid (bricks.comp) covers it: brick min(b, last) (the one extra voxel brick of a grid
// with a multiple of BRICK cells holds only the last point, the last trilinear brick's far
// corner), and superbrick min(s, last) likewise. In a brick clearly on one side of every
// isovalue (range_is_empty) every finite voxel has the same states, so no face inside it is a
// crossing: the walk tests the face it enters the brick through (in its first voxel, as
// always), then jumps to the voxel the ray leaves the brick from (voxel_leave_brick: exactly the
// voxel, and the t, the voxel-by-voxel walk reaches there), reads that voxel's states and leaves
// it as usual. Every channel is bit for bit the same as without skipping, but `steps`: the
// voxels tested plus one per brick crossed in a jump (its first voxel and the jump are one
// pass; a superbrick jump counts the bricks it crosses), as the reference counts them with
// `render.skip` (`reference::skipping`). Rays for which a jump is not exact (`may_jump`, as
// analytic.comp's) walk voxel by voxel.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = RAY_GROUP, local_size_y = RAY_GROUP) in;  // build.rs

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(binding = 1) uniform sampler3D u_grid;
layout(std430, binding = 2) writeonly buffer Out { Pixel pixels[]; };
layout(std430, binding = 3) readonly buffer Colormap { vec4 colormap[256]; };
layout(std430, binding = 4) readonly buffer Bricks { vec2 bricks[]; };
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;

// shade.glsl's `cells` shading checkers voxels (the cell is the inside voxel's point).
#define INTERP_NEAREST 1
#include "field.glsl"
#include "shade.glsl"
#include "camera.glsl"
#include "clip.glsl"
#include "walk.glsl"
#include "bricks.glsl"

// Step 5: the t of the next voxel plane along axis a from voxel v: v + 1/2 going up while
// v < N, v - 1/2 going down while v > 0, else none (+inf): from the plane index, never
// accumulated.
float voxel_tmax(int a, int v, vec3 o, vec3 d, ivec3 ncell) {
    if (d[a] > 0.0 && v < ncell[a]) return (float(v) + 0.5 - o[a]) / d[a];
    if (d[a] < 0.0 && v > 0) return (float(v) - 0.5 - o[a]) / d[a];
    return uintBitsToFloat(0x7f800000u);
}

// The surfaces a finite value is inside of (bit k: surface k), for the walk's states.
uint state_of(float v) {
    return inside_mask(v);
}

// Whether no crossing can lie between voxels of voxel `v`'s brick (the header says why
// trilinear's brick min(b, last) covers it).
bool voxel_brick_is_empty(ivec3 v) {
    ivec3 nb = brick_counts();
    ivec3 b = min(v / BRICK, nb - 1);
    return range_is_empty(bricks[(b.z * nb.y + b.y) * nb.x + b.x]);
}

// The same for its superbrick (SUPER^3 voxel bricks; trilinear's superbrick min(s, last)
// covers each of them, so each of its bricks passes when it does).
bool voxel_superbrick_is_empty(ivec3 v) {
    ivec3 nb = brick_counts();
    ivec3 ns = (nb - 1) / SUPER + 1;
    ivec3 s = min(v / SUPER_CELLS, ns - 1);
    return range_is_empty(bricks[nb.x * nb.y * nb.z + (s.z * ns.y + s.y) * ns.x + s.x]);
}

// The last voxel, in travel order along axis a, of the voxel brick holding voxel v, or of its
// superbrick when `whole`.
int voxel_last_in_block(int a, int v, bool whole, vec3 d) {
    int first = whole ? (v / SUPER_CELLS) * SUPER_CELLS : (v / BRICK) * BRICK;
    int size = whole ? SUPER_CELLS : BRICK;
    return d[a] > 0.0 ? min(first + size - 1, P.dims[a] - 1) : (d[a] < 0.0 ? first : v);
}

// The voxel bricks a brick-by-brick walk from `voxel` crosses before it leaves the superbrick,
// `whole`, or the ray ends (bricks.glsl's brick_jumps on voxel planes).
uint voxel_brick_jumps(ivec3 voxel, float t_hi, vec3 o, vec3 d, ivec3 ncell) {
    ivec3 last;
    vec3 t_next;
    float t_end = t_hi;
    for (int a = 0; a < 3; a++) {
        last[a] = voxel_last_in_block(a, voxel[a], false, d);
        t_next[a] = voxel_tmax(a, last[a], o, d, ncell);
        t_end = min(t_end, voxel_tmax(a, voxel_last_in_block(a, voxel[a], true, d), o, d, ncell));
    }
    uint jumps = 1u;
    for (int i = 0; i < 3 * SUPER; i++) {
        float t_b = min(t_next.x, min(t_next.y, t_next.z));
        if (t_b >= t_end) break;
        jumps++;
        for (int a = 0; a < 3; a++) {
            if (t_next[a] <= t_b) {
                last[a] = voxel_last_in_block(a, last[a] + (d[a] > 0.0 ? 1 : -1), false, d);
                t_next[a] = voxel_tmax(a, last[a], o, d, ncell);
            }
        }
    }
    return jumps;
}

// Crosses the voxel brick (or superbrick, `whole`) holding `voxel` up to its last voxel on the
// ray: returns t_b, where the ray leaves it (at most t_hi), and puts `voxel` and `tmax` in the
// voxel the voxel-by-voxel walk is in when it leaves at t_b: per axis the first voxel, in travel
// order, whose next plane is at t_b or later (found from the position at t_b, corrected
// against the planes' own t, as bricks.glsl's leave_brick). Needs tmax strictly increasing
// along each axis (may_jump) and min(tmax) > the voxel's t_in.
float voxel_leave_brick(inout ivec3 voxel, inout vec3 tmax, float t_hi, vec3 o, vec3 d,
                        bool whole, ivec3 ncell) {
    ivec3 last;
    float t_b = t_hi;
    for (int a = 0; a < 3; a++) {
        last[a] = voxel_last_in_block(a, voxel[a], whole, d);
        t_b = min(t_b, voxel_tmax(a, last[a], o, d, ncell));
    }
    if (t_b >= t_hi) return t_b;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0) continue;
        int s = d[a] > 0.0 ? 1 : -1;
        float x = o[a] + t_b * d[a];
        int c = s > 0 ? int(ceil(x - 0.5)) : int(floor(x + 0.5));
        c = s > 0 ? clamp(c, voxel[a], last[a]) : clamp(c, last[a], voxel[a]);
        for (int i = 0; i <= SUPER_CELLS && c != voxel[a]
                 && voxel_tmax(a, c - s, o, d, ncell) >= t_b; i++)
            c -= s;
        for (int i = 0; i <= SUPER_CELLS && c != last[a]
                 && voxel_tmax(a, c, o, d, ncell) < t_b; i++)
            c += s;
        voxel[a] = c;
        tmax[a] = voxel_tmax(a, c, o, d, ncell);
    }
    return t_b;
}

void main() {
    uvec2 px_local = gl_GlobalInvocationID.xy;
    if (px_local.x >= P.picture_width || px_local.y >= band.rows) return;
    uvec2 px = uvec2(px_local.x, px_local.y + band.row_offset) * P.stride;
    Pixel r = miss_pixel();
    WalkRay w;
    if (!walk_ray(px, w)) {
        pixels[px_local.y * P.picture_width + px_local.x] = r;
        return;
    }
    vec3 eye = w.eye, dir = w.dir, o = w.o, d = w.d, n = w.n, p = w.p;
    float t_lo = w.t_lo, t_hi = w.t_hi;
    ivec3 ncell = P.dims - 1;
    uint surfaces = P.surfaces;
    uint wanted = max(P.crossing, 1u);  // 1 with several surfaces (scene validation)
    bool count_all = P.count_crossings != 0u;
    bool skip = P.skip != 0u;
    // Jumps need tmax strictly increasing along each axis (analytic.comp's may_jump: plane
    // numerators v +- 1/2 - o distinct and ordered, quotients finite and normal).
    bool may_jump = skip && all(lessThan(abs(o), vec3(1048576.0)));
    for (int a = 0; a < 3; a++) {
        float m = abs(d[a]);
        if (m != 0.0 && !(m > 8.0779356694631609e-28 && m < 1.2379400392853803e27)) may_jump = false;
    }

    // 4. First voxel: the kernel's (half up), or exactly on a plane going down, the one the
    // ray heads into.
    ivec3 voxel;
    for (int a = 0; a < 3; a++) {
        float c = clamp(floor(p[a]), 0.0, n[a] - 1.0);
        voxel[a] = int(c) + (p[a] - c >= 0.5 ? 1 : 0);
        if (d[a] < 0.0 && p[a] - c == 0.5) voxel[a] = int(c);
    }

    // 5. Next planes.
    vec3 tmax = vec3(voxel_tmax(0, voxel.x, o, d, ncell), voxel_tmax(1, voxel.y, o, d, ncell),
                     voxel_tmax(2, voxel.z, o, d, ncell));

    // 6. Loop. `known`: the previous voxel was finite, `was` its states; `stepped`: the axes
    // stepped into this voxel.
    float t_in = t_lo;
    bool first = true;
    bool known = false;
    uint was = 0u;
    ivec3 before = voxel;
    bvec3 stepped = bvec3(false);
    uint visited = 0u;
    uint crossings = 0u;   // every surface's, summed (the `crossings` channel)
    uint counts[SURFACES]; // each surface's crossings so far
    for (uint k = 0u; k < SURFACES; k++) counts[k] = 0u;
    bool hit = false;
    float t_hit = 0.0;
    uint hit_surface = 0u;
    uint hit_steps = 0u;
    ivec3 hit_before = voxel;
    ivec3 hit_after = voxel;
    bvec3 hit_stepped = bvec3(false);
    bool hit_entering = false;
    uint max_passes = uint(ncell.x + ncell.y + ncell.z + 1);
    for (uint i = 0u; i < max_passes; i++) {
        visited++;
        // 6.1 The voxel's states.
        float value = texelFetch(u_grid, voxel - P.block_origin, 0).r;
        bool finite = !is_missing(value);
        uint now = finite ? state_of(value) : 0u;
        // 6.2 A crossing on each surface whose state changed on the face just passed.
        if (!first && known && finite && t_in > 0.0) {
            uint flipped = was ^ now;
            for (uint k = 0u; k < surfaces; k++) {
                if ((flipped & (1u << k)) == 0u) continue;
                crossings++;
                counts[k]++;
                if (!hit && counts[k] == wanted) {
                    hit = true;
                    t_hit = t_in;
                    hit_surface = k;
                    hit_steps = visited;
                    hit_before = before;
                    hit_after = voxel;
                    hit_stepped = stepped;
                    hit_entering = (now & (1u << k)) != 0u;
                }
            }
            if (hit && !count_all) break;
        }
        // 6.2b In a brick with no crossing: its last voxel on the ray, whose states the next
        // face is decided on (this voxel's, when the ray leaves the brick from it).
        if (may_jump && voxel_brick_is_empty(voxel) && min(tmax.x, min(tmax.y, tmax.z)) > t_in) {
            bool whole = BRICK_LEVELS > 1 && voxel_superbrick_is_empty(voxel);
            if (whole) visited += voxel_brick_jumps(voxel, t_hi, o, d, ncell) - 1u;
            float t_b = voxel_leave_brick(voxel, tmax, t_hi, o, d, whole, ncell);
            // The rest of the ray lies in the brick: no crossing is left.
            if (t_b >= t_hi) break;
            value = texelFetch(u_grid, voxel - P.block_origin, 0).r;
            finite = !is_missing(value);
            now = finite ? state_of(value) : 0u;
        }
        // 6.3 Leave the voxel.
        float t_out = max(min(min(tmax.x, min(tmax.y, tmax.z)), t_hi), t_in);
        if (t_out >= t_hi) break;
        first = false;
        known = finite;
        was = now;
        before = voxel;
        for (int a = 0; a < 3; a++) {
            stepped[a] = tmax[a] <= t_out;
            if (stepped[a]) {
                voxel[a] += d[a] > 0.0 ? 1 : -1;
                tmax[a] = voxel_tmax(a, voxel[a], o, d, ncell);
            }
        }
        t_in = t_out;
    }

    if (count_all) r.crossings = int(crossings);
    r.steps = float(hit ? hit_steps : visited);
    if (hit) {
        // 7. The face's axis (the lowest stepped), its normal from the inside voxel to the
        // outside one, the inside voxel's point, grid coordinates on the face's plane.
        int axis = hit_stepped.x ? 0 : (hit_stepped.y ? 1 : (hit_stepped.z ? 2 : 0));
        ivec3 vin = hit_entering ? hit_after : hit_before;
        ivec3 vout = hit_entering ? hit_before : hit_after;
        vec3 normal = vec3(0.0);
        normal[axis] = vout[axis] > vin[axis] ? 1.0 : -1.0;
        vec3 u = clamp(o + d * t_hit, vec3(0.0), n);
        for (int a = 0; a < 3; a++) {
            if (hit_stepped[a]) u[a] = float(min(hit_before[a], hit_after[a])) + 0.5;
        }
        r.depth = t_hit;
        r.position = eye + dir * t_hit;
        r.normal = normal;
        r.cell = vin;
        r.surface = surfaces > 1u ? int(hit_surface) : -1;
        r.rgba = vec4(shade(normal, dir, t_hit, r.steps, u, vin,
                            P.surface_color[hit_surface].rgb), 1.0);
    }
    pixels[px_local.y * P.picture_width + px_local.x] = r;
}
