#version 450
// The entry map's raster (passes/entries.rs): for every brick that may hold a surface (listed
// by entries/list.comp), the pixels of the
// band whose rays can meet it, and for each such ray the t where it enters the brick's box,
// kept per pixel as the smallest (atomicMin on the float's bits: t >= 0, so their order is the
// floats'). What is left +inf: the ray meets no such brick, so the walk would find no crossing.
//
// The map must never be late: analytic.comp lands its walk at the map's t, which is exact only
// where that t is not past the walk's entry into the first brick that may hold a surface. So
// the box is widened by ENTRY_MARGIN cells (plus a part of the coordinates' size, for the
// rounding of o + t d), its footprint by two pixels, and the t's are the walk's own plane
// expressions (c - o) / d, which are monotone in c: a ray the walk takes through a brick's cell
// meets the widened box no later than the walk enters the brick.
//
//       eye          footprint: the corners' projections' bounding box, widened; a box
//        *           with a corner behind the eye's plane (perspective) covers the band
//       / \
//   ---+---+---  image plane
//     / ___ \
//    / |   |  \  brick (widened)
//      |___|

#extension GL_GOOGLE_include_directive : require

// One workgroup per listed brick (entries/list.comp), its invocations over the footprint's
// pixels: llvmpipe runs 8 neighbouring pixels' rays in one SIMD group.
layout(local_size_x = ENTRIES_GROUP) in;  // build.rs

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(std430, binding = 1) readonly buffer Bricks { vec2 bricks[]; };
layout(std430, binding = 2) readonly buffer Listed { uint surface_bricks[]; };
layout(std430, binding = 3) readonly buffer Count { uint count; uint groups_x; uint groups_y; uint groups_z; };
layout(std430, binding = 4) buffer Entries { uint entries[]; };
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;

#include "camera.glsl"
#include "clip.glsl"
#include "walk.glsl"
#include "bricks.glsl"
// Cells a brick's box is widened by on every side, before the coordinates' share.
const float ENTRY_MARGIN = 1.0 / 256.0;

// The picture pixels (x0, y0, x1, y1; band rows, inclusive) whose rays may meet the index-space
// box [lo, hi]; false when none do.
bool footprint(vec3 lo, vec3 hi, out ivec4 fp) {
    vec3 spacing = 1.0 / P.inv_spacing;
    float r2 = dot(P.right, P.right);
    float u2 = dot(P.up, P.up);
    vec2 mn = vec2(1e30);
    vec2 mx = vec2(-1e30);
    bool whole = false;
    for (int k = 0; k < 8; k++) {
        vec3 c = vec3((k & 1) != 0 ? hi.x : lo.x, (k & 2) != 0 ? hi.y : lo.y,
                      (k & 4) != 0 ? hi.z : lo.z);
        vec3 v = (c - P.eye_grid) * spacing;  // from the eye, world units (grid frame)
        vec2 s = vec2(dot(v, P.right) / r2, dot(v, P.up) / u2);
        if (!camera_orthographic()) {
            float z = dot(v, P.forward);
            // A corner at or behind the eye's plane: the box's image is not the corners'.
            if (!(z > 1e-6 * length(v))) whole = true;
            s /= z;
        }
        mn = min(mn, s);
        mx = max(mx, s);
    }
    // Image pixel coordinates of the screen coordinates: pixel x's centre is sx = 2 (x + 0.5)
    // / width - 1 (camera.glsl), y's sy = 1 - 2 (y + 0.5) / height.
    vec2 size = vec2(P.width, P.height);
    vec2 x0 = vec2((mn.x + 1.0) * 0.5 * size.x - 0.5, (1.0 - mx.y) * 0.5 * size.y - 0.5) - 2.0;
    vec2 x1 = vec2((mx.x + 1.0) * 0.5 * size.x - 0.5, (1.0 - mn.y) * 0.5 * size.y - 0.5) + 2.0;
    vec2 last = vec2(float(P.picture_width - 1u), float(band.row_offset + band.rows - 1u));
    vec2 first = vec2(0.0, float(band.row_offset));
    vec2 a = first, b = last;
    if (!whole && !any(isnan(x0)) && !any(isnan(x1))) {
        // Picture pixel i is image pixel stride * i.
        float stride = float(P.stride);
        a = max(first, ceil(x0 / stride));
        b = min(last, floor(x1 / stride));
        if (a.x > b.x || a.y > b.y) return false;
    }
    fp = ivec4(ivec2(a) - ivec2(0, int(band.row_offset)), ivec2(b) - ivec2(0, int(band.row_offset)));
    return true;
}

void main() {
    for (uint k = gl_WorkGroupID.x; k < count; k += gl_NumWorkGroups.x) {
        uint b = surface_bricks[k];
        ivec3 nb = brick_counts();
        ivec3 bi = ivec3(int(b) % nb.x, (int(b) / nb.x) % nb.y, int(b) / (nb.x * nb.y));
        // The largest coordinate a ray's o + t d has near the grid, in cells: the origins' (an
        // orthographic ray's is offset from the eye in the image plane) and the grid's.
        float size = max(max(abs(P.eye_grid.x), abs(P.eye_grid.y)), abs(P.eye_grid.z))
            + float(max(max(P.dims.x, P.dims.y), P.dims.z));
        if (camera_orthographic()) {
            float cells = max(max(P.inv_spacing.x, P.inv_spacing.y), P.inv_spacing.z);
            size += (length(P.right) + length(P.up)) * cells;
        }
        float margin = ENTRY_MARGIN + size * (1.0 / 65536.0);
        vec3 lo = vec3(bi * BRICK) - margin;
        vec3 hi = vec3(min((bi + 1) * BRICK, P.dims - 1)) + margin;
        ivec4 fp;
        if (!footprint(lo, hi, fp)) continue;
        uint w = uint(fp.z - fp.x + 1);
        uint pixels = w * uint(fp.w - fp.y + 1);
        for (uint q = gl_LocalInvocationIndex; q < pixels; q += uint(ENTRIES_GROUP)) {
            int i = fp.x + int(q % w);
            int j = fp.y + int(q / w);
            uvec2 px = uvec2(i, j + int(band.row_offset)) * P.stride;
            WalkRay r;
            if (!walk_ray(px, r)) continue;
            // The widened box's slab, with the walk's plane expressions.
            float t_near = r.t_lo;
            float t_far = r.t_hi;
            for (int a = 0; a < 3; a++) {
                if (r.d[a] == 0.0) {
                    if (!(r.o[a] >= lo[a] && r.o[a] <= hi[a])) t_far = -1.0;
                    continue;
                }
                float t0 = (lo[a] - r.o[a]) / r.d[a];
                float t1 = (hi[a] - r.o[a]) / r.d[a];
                t_near = max(t_near, min(t0, t1));
                t_far = min(t_far, max(t0, t1));
            }
            if (!(t_near <= t_far)) continue;
            // +0 for a ray starting in the box (never -0: its bits would sort above +inf's).
            uint key = t_near > 0.0 ? floatBitsToUint(t_near) : 0u;
            atomicMin(entries[uint(j) * P.picture_width + uint(i)], key);
        }
    }
}
