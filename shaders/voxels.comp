#version 450
// Exact ray tracing of the nearest-point interpolant's surface (`render.method = "analytic"`
// with `field.interpolation = "nearest"`): a voxel walk, the port of `reference::voxels`
// (f64), whose module doc is the specification, step for step. The field is constant on each
// point's voxel ([i - 1/2, i + 1/2] per axis, clipped to the box); a crossing is a change of a
// surface's inside predicate between two consecutive voxels, both finite, at the t of the face
// plane, exactly: no root to refine. The walk tests every surface at each face: the first
// face where some surface reaches the wanted crossing is the hit (ties: the lower surface),
// which is the reference's nearest-hit rule over the surfaces traced one by one.
// No empty-space skipping yet: `steps` is the voxels visited, as the reference counts them.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = RAY_GROUP, local_size_y = RAY_GROUP) in;  // build.rs

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(binding = 1) uniform sampler3D u_grid;
layout(std430, binding = 2) writeonly buffer Out { Pixel pixels[]; };
layout(std430, binding = 3) readonly buffer Colormap { vec4 colormap[256]; };
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;

// shade.glsl's `cells` shading checkers voxels (the cell is the inside voxel's point).
#define INTERP_NEAREST 1
#include "field.glsl"
#include "shade.glsl"
#include "camera.glsl"
#include "clip.glsl"
#include "walk.glsl"

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
