#version 450
// The occupancy structure's cell masks (passes/occupancy.rs): for every brick that may hold a
// surface, one bit per cell (bricks.glsl's mask_bit: Morton order in the brick, in MASK_WORDS
// words), set where the trilinear walk would evaluate the cell: not missing and not
// clear of every isovalue (bricks.glsl's cell tests, the walk's own functions on the same
// samples). The walk then reads one word instead of a cell's 8 corners for every cell it steps
// over. Bricks clear of every isovalue get no mask (the walk never reads it: their distance is
// not 0).
//
// One invocation per word: 32 cells, four 2^3 blocks.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = OCCUPANCY_GROUP) in;  // build.rs

#include "params.glsl"

// RenderParams as a storage buffer, not a uniform one: lavapipe (Mesa 22) compiles a variant of
// a pipeline for each dispatch whose uniforms it can inline into the code, and frees them only
// with the pipeline; storage buffers it never inlines, so this pass is compiled once.
layout(std140, binding = 0) readonly buffer Params { RenderParams P; };
layout(std430, binding = 1) readonly buffer Grid { float grid[]; };
layout(std430, binding = 2) readonly buffer Bricks { vec2 bricks[]; };
layout(std430, binding = 3) writeonly buffer Masks { uint masks[]; };

#define GRID_BUFFER
#include "field.glsl"
#define CELL_TESTS
#include "bricks.glsl"

void main() {
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * uint(OCCUPANCY_GROUP)
        + gl_GlobalInvocationID.x;
    ivec3 nb = brick_counts();
    uint brick = i / uint(MASK_WORDS);
    if (brick >= uint(nb.x * nb.y * nb.z) || range_is_empty(bricks[brick])) return;
    int word = int(i % uint(MASK_WORDS));
    ivec3 b = ivec3(int(brick) % nb.x, (int(brick) / nb.x) % nb.y, int(brick) / (nb.x * nb.y));
    ivec3 ncell = P.dims - 1;
    uint bits = 0u;
    for (uint k = 0u; k < 32u; k++) {
        ivec3 c = b * BRICK + mask_cell(uint(word) * 32u + k);
        if (any(greaterThanEqual(c, ncell))) continue;
        Corners corners = cell_corners(c);
        if (!cell_missing(corners) && !cell_all_clear(corners)) bits |= 1u << k;
    }
    masks[i] = bits;
}
