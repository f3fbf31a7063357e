#version 450
// The entry map's sort (passes/entries.rs): every pixel of the band either gets its miss
// record here (its ray misses the box, or meets no brick that may hold a surface: the map's
// +inf) or is listed for analytic.comp's walk (`rays`, counted in `listed`, with the
// workgroups of the walk's indirect dispatch from `listed_groups_x`). Rays whose jumps are not
// exact (bricks.glsl's jumps_exact) are always listed: they walk cell by cell from the start.
// The walk then runs only where there is work: llvmpipe runs a shader's whole body under a
// mask for every group of 8 invocations, so idle lanes in the walk's groups cost as much as busy
// ones.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = RAY_GROUP, local_size_y = RAY_GROUP) in;  // build.rs

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(std430, binding = 1) readonly buffer Entries { uint entries[]; };
layout(std430, binding = 2) writeonly buffer Out { Pixel pixels[]; };
layout(std430, binding = 3) writeonly buffer Active { uint rays[]; };
layout(std430, binding = 4) buffer Listed { uint listed; uint listed_groups_x; uint listed_groups_y; uint listed_groups_z; };
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;

#include "camera.glsl"
#include "clip.glsl"
#include "walk.glsl"
#include "jumps.glsl"

void main() {
    uvec2 px_local = gl_GlobalInvocationID.xy;
    if (px_local.x >= P.picture_width || px_local.y >= band.rows) return;
    uint pix = px_local.y * P.picture_width + px_local.x;
    uvec2 px = uvec2(px_local.x, px_local.y + band.row_offset) * P.stride;
    WalkRay w;
    bool walk = walk_ray(px, w)
        && (entries[pix] != 0x7f800000u || !jumps_exact(w.o, w.d));
    if (!walk) {
        pixels[pix] = miss_pixel();
        return;
    }
    uint at = atomicAdd(listed, 1u);
    rays[at] = pix;
    // One more workgroup of the walk for each RAY_GROUP^2 rays listed.
    if (at % uint(RAY_GROUP * RAY_GROUP) == 0u) atomicAdd(listed_groups_x, 1u);
}
