#version 450
// The min/max grid of empty-space skipping (`src/passes/bricks.rs`): one invocation per brick of
// `size`^3 cells, writing the smallest and largest of the grid values at the points its cells
// read (`Stencil::brick_points`; trilinear: (size + 1)^3, a brick's cells share their boundary
// points with the next brick). Every value of the trilinear field inside the brick's cells is a
// convex combination of these, so it lies in [min, max].
//
// Variants (build.rs): BRICKS_CUBIC covers the tricubic stencils instead (one point below a
// brick's cells and two above: (size + 3)^3), whose B-spline values and Bernstein coefficients
// are convex combinations of them; BRICKS_WIDEN (Catmull-Rom, not convex) then widens [m, M] to
// [m - k (M - m), M + k (M - m)] with k = CATMULL_ROM_KAPPA_BITS (37/54, `cubic`'s "Bounds"
// proves it), in `precise` f32 so the CPU twin (`bricks::reference_for`) has the same bits.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = BRICKS_GROUP, local_size_y = BRICKS_GROUP, local_size_z = BRICKS_GROUP) in;  // build.rs

#include "missing.glsl"

layout(binding = 0) uniform sampler3D u_grid;
layout(std430, binding = 1) writeonly buffer Bricks { vec2 bricks[]; };
layout(push_constant) uniform Shape {
    ivec4 points;  // xyz: grid points per axis, w: the buffer index of the level's first range
    ivec4 bricks;  // xyz: bricks per axis, w: brick size in cells (BRICK, or FINE)
} shape;

void main() {
    ivec3 b = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(b, shape.bricks.xyz))) return;
    int size = shape.bricks.w;
    // The brick's cells b size .. min((b + 1) size, n - 1) and their stencil, inside the grid.
    ivec3 cells = shape.points.xyz - 1;
#ifdef BRICKS_CUBIC
    const int below = CUBIC_STENCIL_BELOW, above = CUBIC_STENCIL_ABOVE;
#else
    const int below = STENCIL_BELOW, above = STENCIL_ABOVE;
#endif
    ivec3 lo = max(min(b * size, cells) - below, 0);
    ivec3 hi = min(min(b * size + size, cells) - 1 + above, shape.points.xyz - 1);
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
#ifdef BRICKS_WIDEN
    // [inf, -inf] (no finite sample) stays itself: inf - k (-inf) = inf, -inf + k (-inf) = -inf.
    precise float spread = uintBitsToFloat(CATMULL_ROM_KAPPA_BITS) * (vmax - vmin);
    precise float wmin = vmin - spread;
    precise float wmax = vmax + spread;
    vmin = wmin;
    vmax = wmax;
#endif
    bricks[shape.points.w + (b.z * shape.bricks.y + b.y) * shape.bricks.x + b.x] = vec2(vmin, vmax);
}
