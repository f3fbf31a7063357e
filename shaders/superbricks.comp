#version 450
// The coarser level of the min/max grid (`src/passes/bricks.rs`): one invocation per superbrick
// of SUPER^3 bricks, writing the smallest minimum and the largest maximum of its bricks' ranges
// (bricks.comp's output, in the same buffer) after the bricks. The field inside the superbrick's
// cells lies in each of its bricks' ranges, so in their union.

layout(local_size_x = BRICKS_GROUP, local_size_y = BRICKS_GROUP, local_size_z = BRICKS_GROUP) in;  // build.rs

layout(std430, binding = 0) buffer Bricks { vec2 bricks[]; };
layout(push_constant) uniform SuperShape {
    ivec4 supers;  // xyz: superbricks per axis, w: SUPER
    ivec4 bricks;  // xyz: bricks per axis
} shape;

void main() {
    ivec3 s = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(s, shape.supers.xyz))) return;
    ivec3 nb = shape.bricks.xyz;
    ivec3 lo = s * SUPER;
    ivec3 hi = min(lo + SUPER, nb) - 1;
    vec2 mm = bricks[(lo.z * nb.y + lo.y) * nb.x + lo.x];
    for (int z = lo.z; z <= hi.z; z++) {
        for (int y = lo.y; y <= hi.y; y++) {
            for (int x = lo.x; x <= hi.x; x++) {
                vec2 b = bricks[(z * nb.y + y) * nb.x + x];
                mm = vec2(min(mm.x, b.x), max(mm.y, b.y));
            }
        }
    }
    int first = nb.x * nb.y * nb.z;  // the superbricks follow the bricks
    bricks[first + (s.z * shape.supers.y + s.y) * shape.supers.x + s.x] = mm;
}
