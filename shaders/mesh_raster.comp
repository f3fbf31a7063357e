#version 450
// Mesh render, pass 1 of 2 (`render.method = "mesh"`): visibility by compute "rasterisation".
// One invocation per triangle, for one band of image rows:
//   1. project the vertices to pixel coordinates and take the bounding box, widened by a pixel
//      (the whole band when a vertex is not in front of the eye);
//   2. for every pixel centre in the box, intersect the pixel's ray with the triangle exactly
//      (watertight test, `triangle.glsl`) and count the test;
//   3. on a hit at t > 0, count it and atomicMin the pixel's 64-bit key (t bits << 32 | id):
//      positive floats order like their bits, so the key keeps the nearest hit, ties going to
//      the lower triangle id (deterministic).
// Pass 2 (`mesh_resolve.comp`) turns the winning key into the pixel's channels.
// Mirrors `reference::mesh` (f64).

#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require

layout(local_size_x = RASTER_GROUP) in;  // build.rs

#include "params.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(std430, binding = 1) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = 2) readonly buffer Indices { uint indices[]; };
layout(std430, binding = 3) buffer Visibility { uint64_t vis[]; };
// Per pixel of the band: [2i] triangles tested, [2i + 1] triangles hit at t > 0.
layout(std430, binding = 4) buffer Counts { uint counts[]; };
layout(push_constant) uniform Push {
    uint row_offset;
    uint rows;
    uint triangle_count;
    uint threads_x;  // invocations per row of the 2D dispatch
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
    uint tri = gl_GlobalInvocationID.y * pc.threads_x + gl_GlobalInvocationID.x;
    if (tri >= pc.triangle_count) return;
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
    if (min(za, min(zb, zc)) > 0.0) {
        vec2 pa = to_pixel(qa, za);
        vec2 pb = to_pixel(qb, zb);
        vec2 pc2 = to_pixel(qc, zc);
        vec2 lo = clamp(min(pa, min(pb, pc2)), vec2(-2.0), vec2(P.width, P.height) + 1.0);
        vec2 hi = clamp(max(pa, max(pb, pc2)), vec2(-2.0), vec2(P.width, P.height) + 1.0);
        x0 = max(x0, int(floor(lo.x)) - 1);
        x1 = min(x1, int(ceil(hi.x)) + 1);
        y0 = max(y0, int(floor(lo.y)) - 1);
        y1 = min(y1, int(ceil(hi.y)) + 1);
    }

    for (int y = y0; y <= y1; y++) {
        for (int x = x0; x <= x1; x++) {
            uint i = uint(y - int(pc.row_offset)) * P.width + uint(x);
            vec3 ro;
            vec3 d;
            camera_ray(uvec2(x, y), ro, d);
            atomicAdd(counts[2u * i], 1u);
            // Clip planes: only hits in the kept interval count.
            float c0 = 0.0;
            float c1 = uintBitsToFloat(0x7f800000u);
            if (!clip_interval(ro, d, c0, c1)) continue;
            float t;
            vec3 bary;
            if (intersect_triangle(ro, ray_shear(d), A, B, C, t, bary) && t > 0.0 && t >= c0
                && t <= c1) {
                atomicAdd(counts[2u * i + 1u], 1u);
                atomicMin(vis[i], (uint64_t(floatBitsToUint(t)) << 32) | uint64_t(tri));
            }
        }
    }
}
