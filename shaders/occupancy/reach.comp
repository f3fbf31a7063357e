#version 450
// The occupancy structure's distances (passes/occupancy.rs): for every brick, how far the
// nearest brick that may hold a surface is, in bricks, in the L-infinity metric (the largest of
// the three axis distances), capped: 0 for a brick that may hold one (its min/max range is not
// clear of every isovalue: bricks.glsl's range_is_empty), r >= 1 for an empty brick, whose
// neighbours up to r - 1 bricks away on every axis are all empty too, so the walk may cross the
// whole cube of (2r - 1)^3 bricks around it in one jump; REACH_CAP + 1 means at least that.
//
// Three passes, one per axis (push constant `axis`), each a windowed min over that axis:
//   axis 0: d0(b) = min over |k| <= REACH_CAP of max(|k|, occupied(b + k x) ? 0 : CAP + 1)
//   axis 1: d1(b) = min over |k| of max(|k|, d0(b + k y));   axis 2: the same over z
// whose composition is the L-infinity distance, exact up to the cap: min over y of the max of
// the three axis distances |b_a - y_a|, taken one axis at a time.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = OCCUPANCY_GROUP) in;  // build.rs

#include "params.glsl"

// RenderParams as a storage buffer, not a uniform one: lavapipe (Mesa 22) compiles a variant of
// a pipeline for each dispatch whose uniforms it can inline into the code, and frees them only
// with the pipeline; storage buffers it never inlines, so this pass is compiled once.
layout(std140, binding = 0) readonly buffer Params { RenderParams P; };
layout(std430, binding = 1) readonly buffer Bricks { vec2 bricks[]; };
layout(std430, binding = 2) readonly buffer Src { uint src[]; };
layout(std430, binding = 3) writeonly buffer Dst { uint dst[]; };
// The axis of this pass (0, 1, 2), written before each dispatch: not a push constant, for the
// same reason as Params.
layout(std430, binding = 4) readonly buffer Pass { int axis; } pass;

#include "bricks.glsl"

void main() {
    // Bricks are x fastest; the dispatch is spread over x and y (gpu::spread_groups).
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * uint(OCCUPANCY_GROUP)
        + gl_GlobalInvocationID.x;
    ivec3 nb = brick_counts();
    if (i >= uint(nb.x * nb.y * nb.z)) return;
    ivec3 b = ivec3(int(i) % nb.x, (int(i) / nb.x) % nb.y, int(i) / (nb.x * nb.y));
    int a = pass.axis;
    int stride = a == 0 ? 1 : (a == 1 ? nb.x : nb.x * nb.y);
    uint far = uint(REACH_CAP + 1);
    uint best = far;
    for (int k = -REACH_CAP; k <= REACH_CAP; k++) {
        int c = b[a] + k;
        if (c < 0 || c >= nb[a]) continue;
        uint j = uint(int(i) + k * stride);
        uint v = a == 0 ? (range_is_empty(bricks[j]) ? far : 0u) : src[j];
        best = min(best, max(uint(abs(k)), v));
    }
    dst[i] = best;
}
