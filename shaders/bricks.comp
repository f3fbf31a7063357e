#version 450
// The min/max grid of empty-space skipping (`src/passes/bricks.rs`): one invocation per brick of
// `size`^3 cells, writing the smallest and largest of the grid values at the points its cells
// read (`Stencil::brick_points`; trilinear: (size + 1)^3, a brick's cells share their boundary
// points with the next brick). Every value of the trilinear field inside the brick's cells is a
// convex combination of these, so it lies in [min, max].

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = BRICKS_GROUP, local_size_y = BRICKS_GROUP, local_size_z = BRICKS_GROUP) in;  // build.rs

#include "missing.glsl"

layout(binding = 0) uniform sampler3D u_grid;
layout(std430, binding = 1) writeonly buffer Bricks { vec2 bricks[]; };
layout(push_constant) uniform Shape {
    ivec4 points;  // xyz: grid points per axis
    ivec4 bricks;  // xyz: bricks per axis, w: brick size in cells
} shape;

void main() {
    ivec3 b = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(b, shape.bricks.xyz))) return;
    int size = shape.bricks.w;
    // The brick's cells b size .. min((b + 1) size, n - 1) and their stencil, inside the grid.
    ivec3 cells = shape.points.xyz - 1;
    ivec3 lo = max(min(b * size, cells) - STENCIL_BELOW, 0);
    ivec3 hi = min(min(b * size + size, cells) - 1 + STENCIL_ABOVE, shape.points.xyz - 1);
    // Missing samples (NaN, inf) are left out (`field::interpolant::widen`): GLSL's min/max are undefined
    // with NaN. A brick with no finite sample keeps [inf, -inf], which no range test calls clear.
    float vmin = uintBitsToFloat(0x7f800000u);
    float vmax = -vmin;
    for (int z = lo.z; z <= hi.z; z++) {
        for (int y = lo.y; y <= hi.y; y++) {
            for (int x = lo.x; x <= hi.x; x++) {
                float v = texelFetch(u_grid, ivec3(x, y, z), 0).r;
                if (is_missing(v)) continue;
                vmin = min(vmin, v);
                vmax = max(vmax, v);
            }
        }
    }
    bricks[(b.z * shape.bricks.y + b.y) * shape.bricks.x + b.x] = vec2(vmin, vmax);
}
