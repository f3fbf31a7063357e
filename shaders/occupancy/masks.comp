#version 450
// The occupancy structure's cell masks (passes/occupancy.rs): for every brick that may hold a
// surface, one bit per cell (bit x + BRICK (y + BRICK z) of the brick's cell (x, y, z), in
// MASK_WORDS words), set where the trilinear walk would evaluate the cell: not missing and not
// clear of every isovalue (bricks.glsl's cell tests, the walk's own functions on the same
// samples). The walk then reads one word instead of a cell's 8 corners for every cell it steps
// over. Bricks clear of every isovalue get no mask (the walk never reads it: their distance is
// not 0).
//
// One invocation per word: 32 cells, 32 / BRICK rows of BRICK cells along x.

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
    for (int r = 0; r < 32 / BRICK; r++) {
        int row = word * (32 / BRICK) + r;     // y + BRICK z within the brick
        ivec3 c0 = b * BRICK + ivec3(0, row % BRICK, row / BRICK);
        if (c0.y >= ncell.y || c0.z >= ncell.z) continue;
        for (int x = 0; x < BRICK; x++) {
            ivec3 c = c0 + ivec3(x, 0, 0);
            if (c.x >= ncell.x) break;
            Corners k = cell_corners(c);
            if (!cell_missing(k) && !cell_all_clear(k)) bits |= 1u << uint(r * BRICK + x);
        }
    }
    masks[i] = bits;
}
