#version 450
// The entry map's bricks (passes/entries.rs): the bricks that may hold a surface (their min/max
// range not clear of every isovalue: bricks.glsl's range_is_empty), listed for the raster,
// with the raster's workgroup count (one per listed brick, at most MAX_GROUPS_X: each group
// then takes every MAX_GROUPS_X-th) for its indirect dispatch.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = ENTRIES_GROUP) in;  // build.rs

#include "params.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(std430, binding = 1) readonly buffer Bricks { vec2 bricks[]; };
layout(std430, binding = 2) writeonly buffer Listed { uint surface_bricks[]; };
layout(std430, binding = 3) buffer Count { uint count; uint groups_x; uint groups_y; uint groups_z; };

#include "bricks.glsl"

void main() {
    // Bricks are x fastest; the dispatch is spread over x and y (gpu::spread_groups).
    uint b = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * uint(ENTRIES_GROUP)
        + gl_GlobalInvocationID.x;
    ivec3 nb = brick_counts();
    if (b >= uint(nb.x * nb.y * nb.z) || range_is_empty(bricks[b])) return;
    uint at = atomicAdd(count, 1u);
    surface_bricks[at] = b;
    if (at < 65535u) atomicAdd(groups_x, 1u);
}
