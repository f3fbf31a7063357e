#version 450
// Mesh render, pass 1 of 2 (`render.method = "mesh"`): visibility by compute "rasterisation".
// One invocation per triangle, for one band of image rows:
//   1. project the vertices to pixel coordinates and take the bounding box, widened by a pixel
//      (where a vertex is not in front of the eye, of the part that is: below);
//   2. for every pixel centre in the box, intersect the pixel's ray with the triangle exactly
//      (watertight test, `triangle.glsl`) and count the test;
//   3. on a hit at t > 0, count it and atomicMin the pixel's 64-bit key (t bits << 32 | id):
//      positive floats order like their bits, so the key keeps the nearest hit, ties going to
//      the lower triangle id (deterministic).
// Pass 2 (`mesh_resolve.comp`) turns the winning key into the pixel's channels.
//
// llvmpipe ends every loop of an invocation after 65,535 passes in all (gallivm's
// LP_MAX_TGSI_LOOP_ITERATIONS; raymarch.comp's LONG_MARCH), silently: a triangle whose box
// held more pixels than that was drawn only in its first rows (a coarse mesh up close at 1024^2
// lost 434,610 pixels). So an invocation tests at most `chunk_pixels` pixels (the host makes
// that times the passes a pixel costs, one plus the clip planes' loop, at most 60,000): a
// triangle with more is listed by the first stage (`stage` 0) and drawn by the second (1), an
// indirect dispatch of one invocation per chunk of `chunk_pixels` pixels of each listed
// triangle's box, in the box's row order. Hits are atomic minima and the counts sums: the same
// result in any order.
// Mirrors `reference::mesh` (f64).

#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_control_flow_attributes : require

layout(local_size_x = RASTER_GROUP) in;  // build.rs

#include "params.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(std430, binding = 1) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = 2) readonly buffer Indices { uint indices[]; };
layout(std430, binding = 3) buffer Visibility { uint64_t vis[]; };
// Per pixel of the band: [2i] triangles tested, [2i + 1] triangles hit at t > 0.
layout(std430, binding = 4) buffer Counts { uint counts[]; };
// The triangles the first stage lists (passes::mesh_render::LARGE_CAPACITY at most) and the
// second stage's indirect dispatch: x, chunks (the host's), y, one row of workgroups per listed
// triangle; `overflow` counts triangles past the capacity (the render then fails).
layout(std430, binding = 5) buffer Large { uint large[]; };
layout(std430, binding = 6) buffer LargeCount {
    uint large_count;
    uint groups_x;
    uint groups_y;
    uint groups_z;
    uint overflow;
};
layout(push_constant) uniform Push {
    uint row_offset;
    uint rows;
    uint triangle_count;
    uint threads_x;  // invocations per row of the 2D dispatch
    uint chunk_pixels;  // most pixels one invocation tests
    uint stage;         // 0: every triangle (listing the large); 1: chunks of the listed
} pc;

#include "camera.glsl"
#include "clip.glsl"
#include "triangle.glsl"

// Continuous pixel coordinates (x right, y down; pixel centres at integer + 0.5 - 0.5) of
// eye-relative point q at depth z > 0 along the view (orthographic: no division by depth).
vec2 to_pixel(vec3 q, float z) {
    if (camera_orthographic()) z = 1.0;
    float sx = dot(q, P.right) / (dot(P.right, P.right) * z);
    float sy = dot(q, P.up) / (dot(P.up, P.up) * z);
    return vec2((sx + 1.0) * 0.5 * float(P.width) - 0.5, (1.0 - sy) * 0.5 * float(P.height) - 0.5);
}

void main() {
    uint tri;
    uint chunk = 0u;
    if (pc.stage == 0u) {
        tri = gl_GlobalInvocationID.y * pc.threads_x + gl_GlobalInvocationID.x;
        if (tri >= pc.triangle_count) return;
    } else {
        tri = large[gl_WorkGroupID.y];
        chunk = gl_GlobalInvocationID.x;
    }
    vec3 A = positions[indices[3u * tri]].xyz;
    vec3 B = positions[indices[3u * tri + 1u]].xyz;
    vec3 C = positions[indices[3u * tri + 2u]].xyz;
    vec3 o = P.eye;

    // Bounding box in pixels, clamped to the band.
    int x0 = 0;
    int x1 = int(P.width) - 1;
    int y0 = int(pc.row_offset);
    int y1 = int(pc.row_offset + pc.rows) - 1;
    vec3 qa = A - o;
    vec3 qb = B - o;
    vec3 qc = C - o;
    float za = dot(qa, P.forward);
    float zb = dot(qb, P.forward);
    float zc = dot(qc, P.forward);
    if (za <= 0.0 && zb <= 0.0 && zc <= 0.0) return;  // wholly behind the eye
    // The box of what lies in front of the eye (`reference::mesh::screen_box`'s rule): its
    // vertices there, projected, and for each edge that crosses the eye's plane, the way its
    // far part runs off the screen (its point on the plane, seen as a direction): the box then
    // reaches the picture's edge that way, both ways where the direction is within 1e-3 of
    // square to the axis (f32 and f64 decide alike), the whole band for an edge through the
    // eye. Orthographic: every vertex, projected (no division by depth).
    vec3 q[3] = vec3[3](qa, qb, qc);
    float z[3] = float[3](za, zb, zc);
    float INF = uintBitsToFloat(0x7f800000u);
    vec2 lo = vec2(INF);
    vec2 hi = vec2(-INF);
    [[unroll]] for (int i = 0; i < 3; i++) {
        if (z[i] > 0.0 || camera_orthographic()) {
            vec2 p = to_pixel(q[i], z[i]);
            lo = min(lo, p);
            hi = max(hi, p);
        }
        int j = (i + 1) % 3;
        if (!camera_orthographic() && (z[i] > 0.0) != (z[j] > 0.0)) {
            float s = z[i] / (z[i] - z[j]);
            vec3 c = q[i] + s * (q[j] - q[i]);
            vec2 dir = vec2(dot(c, P.right) / dot(P.right, P.right),
                            -(dot(c, P.up) / dot(P.up, P.up)));
            float tol = 1e-3 * (abs(dir.x) + abs(dir.y));
            if (dir.x >= -tol) hi.x = INF;
            if (dir.x <= tol) lo.x = -INF;
            if (dir.y >= -tol) hi.y = INF;
            if (dir.y <= tol) lo.y = -INF;
        }
    }
    lo = clamp(lo, vec2(-2.0), vec2(P.width, P.height) + 1.0);
    hi = clamp(hi, vec2(-2.0), vec2(P.width, P.height) + 1.0);
    x0 = max(x0, int(floor(lo.x)) - 1);
    x1 = min(x1, int(ceil(hi.x)) + 1);
    y0 = max(y0, int(floor(lo.y)) - 1);
    y1 = min(y1, int(ceil(hi.y)) + 1);

    if (x1 < x0 || y1 < y0) return;
    uint w = uint(x1 - x0 + 1);
    uint total = w * uint(y1 - y0 + 1);  // at most the band's pixels
    if (pc.stage == 0u && total > pc.chunk_pixels) {
        uint k = atomicAdd(large_count, 1u);
        if (k < LARGE_CAPACITY) {
            large[k] = tri;
            atomicAdd(groups_y, 1u);
        } else {
            atomicAdd(overflow, 1u);
        }
        return;
    }
    uint k0 = chunk * pc.chunk_pixels;
    if (k0 >= total) return;
    uint k1 = min(total, k0 + pc.chunk_pixels);
    // The box's pixels k0 .. k1 - 1, row by row (one loop: its passes are its pixels).
    int x = x0 + int(k0 % w);
    int y = y0 + int(k0 / w);
    for (uint k = k0; k < k1; k++) {
        uint i = uint(y - int(pc.row_offset)) * P.width + uint(x);
        vec3 ro;
        vec3 d;
        camera_ray(uvec2(x, y), ro, d);
        atomicAdd(counts[2u * i], 1u);
        // Clip planes: only hits in the kept interval count.
        float c0 = 0.0;
        float c1 = uintBitsToFloat(0x7f800000u);
        float t;
        vec3 bary;
        if (clip_interval(ro, d, c0, c1) && intersect_triangle(ro, ray_shear(d), A, B, C, t, bary)
            && t > 0.0 && t >= c0 && t <= c1) {
            atomicAdd(counts[2u * i + 1u], 1u);
            atomicMin(vis[i], (uint64_t(floatBitsToUint(t)) << 32) | uint64_t(tri));
        }
        x++;
        if (x > x1) {
            x = x0;
            y++;
        }
    }
}
