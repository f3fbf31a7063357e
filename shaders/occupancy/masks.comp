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
#extension GL_EXT_control_flow_attributes : require

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

// The 32 cells of a word: Morton bits 0-4 (x0 y0 z0 x1 y1) vary, so they are a block of 4 x 4 x
// 2 cells whose 5 x 5 x 3 points are read once (3.4 reads a cell, not 8), and each cell's
// smallest and largest corner are taken separably, x pairs, then y, then z: exact values in
// any order. Unrolled, so every index is a constant (llvmpipe keeps run-time indexed arrays in
// memory, with lane-dependent results: docs/limitations.md).
void main() {
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * uint(OCCUPANCY_GROUP)
        + gl_GlobalInvocationID.x;
    ivec3 nb = brick_counts();
    uint brick = i / uint(MASK_WORDS);
    if (brick >= uint(nb.x * nb.y * nb.z) || range_is_empty(bricks[brick])) return;
    int word = int(i % uint(MASK_WORDS));
    ivec3 b = ivec3(int(brick) % nb.x, (int(brick) / nb.x) % nb.y, int(brick) / (nb.x * nb.y));
    ivec3 ncell = P.dims - 1;
    ivec3 origin = b * BRICK + mask_cell(uint(word) * 32u);
    // The points, clamped into the grid (a clamped point only serves cells outside it).
    float v[75];
    [[unroll]] for (int z = 0; z < 3; z++) {
        [[unroll]] for (int y = 0; y < 5; y++) {
            [[unroll]] for (int x = 0; x < 5; x++) {
                ivec3 p = min(origin + ivec3(x, y, z), ncell);
                v[(z * 5 + y) * 5 + x] = grid[grid_index(p)];
            }
        }
    }
    // Missing points (NaN, inf) make their cells missing; min and max only ever meet finite
    // values of the cells that are not.
    bool gone[75];
    [[unroll]] for (int n = 0; n < 75; n++) gone[n] = is_missing(v[n]);
    float lo_x[60], hi_x[60];
    bool gone_x[60];
    [[unroll]] for (int z = 0; z < 3; z++) {
        [[unroll]] for (int y = 0; y < 5; y++) {
            [[unroll]] for (int x = 0; x < 4; x++) {
                int s = (z * 5 + y) * 5 + x;
                int t = (z * 5 + y) * 4 + x;
                lo_x[t] = min(v[s], v[s + 1]);
                hi_x[t] = max(v[s], v[s + 1]);
                gone_x[t] = gone[s] || gone[s + 1];
            }
        }
    }
    float lo_y[48], hi_y[48];
    bool gone_y[48];
    [[unroll]] for (int z = 0; z < 3; z++) {
        [[unroll]] for (int y = 0; y < 4; y++) {
            [[unroll]] for (int x = 0; x < 4; x++) {
                int s = (z * 5 + y) * 4 + x;
                int t = (z * 4 + y) * 4 + x;
                lo_y[t] = min(lo_x[s], lo_x[s + 4]);
                hi_y[t] = max(hi_x[s], hi_x[s + 4]);
                gone_y[t] = gone_x[s] || gone_x[s + 4];
            }
        }
    }
    uint bits = 0u;
    [[unroll]] for (uint k = 0u; k < 32u; k++) {
        ivec3 l = mask_cell(k);  // within the 4 x 4 x 2 block
        int s = (l.z * 4 + l.y) * 4 + l.x;
        float lo = min(lo_y[s], lo_y[s + 16]);
        float hi = max(hi_y[s], hi_y[s + 16]);
        bool missing = gone_y[s] || gone_y[s + 16];
        bool outside = any(greaterThanEqual(origin + l, ncell));
        // A candidate: not missing, not clear of every surface (cell_all_clear's test).
        bool clear_all = true;
        for (uint s2 = 0u; s2 < SURFACE_COUNT; s2++) {
            clear_all = clear_all && values_clear(lo, hi, threshold(s2));
        }
        if (!missing && !outside && !clear_all) bits |= 1u << k;
    }
    masks[i] = bits;
}
