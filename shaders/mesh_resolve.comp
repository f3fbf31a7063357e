#version 450
// Mesh render, pass 2 of 2: one invocation per pixel of the band turns the visibility key left
// by `mesh_raster.comp` into the pixel's channels, as the ray passes write them:
//   Z      the winning t (the raster's own value, so Z is exactly the nearest hit found);
//   P      eye + t d;
//   N      the vertex normals interpolated with the hit's barycentric weights, normalised
//          (inside -> outside; the triangle's geometric normal where they cancel);
//   cell   the grid cell holding P (`cell_of`, as the ray passes);
//   steps  triangles tested for this pixel (those whose widened screen box held it);
//   crossings  triangles the ray hit at t > 0 (surface crossings, as analytic counts them),
//              or -1 unless `render.count_crossings`;
//   RGB    `shade()`, A = 1 on a hit; the background on a miss.
// Mirrors `reference::mesh` (f64).

#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(local_size_x = RAY_GROUP, local_size_y = RAY_GROUP) in;  // build.rs

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(binding = 1) uniform sampler3D u_grid;
layout(std430, binding = 2) writeonly buffer Out { Pixel pixels[]; };
layout(std430, binding = 3) readonly buffer Colormap { vec4 colormap[256]; };
layout(std430, binding = 4) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = 5) readonly buffer Normals { vec4 normals[]; };
layout(std430, binding = 6) readonly buffer Indices { uint indices[]; };
layout(std430, binding = 7) readonly buffer Visibility { uint64_t vis[]; };
layout(std430, binding = 8) readonly buffer Counts { uint counts[]; };
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;

#include "field.glsl"
#include "shade.glsl"
#include "camera.glsl"
#include "triangle.glsl"

const uint64_t NO_HIT = 0xFFFFFFFFFFFFFFFFul;

void main() {
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= P.width || local.y >= band.rows) return;
    uvec2 px = uvec2(local.x, local.y + band.row_offset);
    uint i = local.y * P.width + local.x;
    vec3 o;
    vec3 d;
    camera_ray(px, o, d);

    Pixel r;
    r.rgba = P.background;
    r.normal = vec3(0.0);
    r.depth = 1.0 / 0.0;
    r.position = vec3(0.0);
    r.steps = float(counts[2u * i]);
    r.cell = ivec3(-1);
    // Counted only when asked for (`render.count_crossings`, P.count_crossings); -1: no channel.
    r.crossings = P.count_crossings != 0u ? int(counts[2u * i + 1u]) : -1;
    // One surface per pass: several isovalues are drawn one after the other and composited
    // on the host (`render::mesh`), which sets `surface`.
    r.surface = -1;
    r.value = uintBitsToFloat(0x7fc00000u);  // NaN: no [color] value
    r.pad0 = 0u;
    r.pad1 = 0u;

    uint64_t key = vis[i];
    if (key != NO_HIT) {
        uint tri = uint(key & 0xFFFFFFFFul);
        float t = uintBitsToFloat(uint(key >> 32));
        uvec3 v = uvec3(indices[3u * tri], indices[3u * tri + 1u], indices[3u * tri + 2u]);
        vec3 A = positions[v.x].xyz;
        vec3 B = positions[v.y].xyz;
        vec3 C = positions[v.z].xyz;
        vec3 w = plane_barycentrics(o, ray_shear(d), A, B, C);
        vec3 n = w.x * normals[v.x].xyz + w.y * normals[v.y].xyz + w.z * normals[v.z].xyz;
        float len = length(n);
        if (len > 0.0) {
            n /= len;
        } else {
            vec3 g = cross(B - A, C - A);
            n = length(g) > 0.0 ? normalize(g) : -d;
        }
        vec3 hit = o + d * t;
        vec3 u = to_grid(hit);
        n = scene_normal(u, cell_of(u), n);
        r.depth = t;
        r.position = hit;
        r.normal = n;
        r.cell = cell_of(u);
        r.rgba = vec4(shade(n, d, t, r.steps, u, r.cell, P.color), 1.0);
    }
    pixels[i] = r;
}
