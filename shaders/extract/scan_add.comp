#version 450
// Extraction pass `scan add`: adds the scanned block sums to the block-scanned `data`
// (`scan.comp`): element i gets sums[i / 1024].

layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

layout(std430, binding = 0) buffer Data { uint data[]; };
layout(std430, binding = 1) readonly buffer Sums { uint sums[]; };

layout(push_constant) uniform Push {
    uint groups_x;
    uint count;
} C;

void main() {
    uint block = gl_WorkGroupID.x + gl_WorkGroupID.y * C.groups_x;
    uint base = block * SCAN_BLOCK + gl_LocalInvocationID.x * SCAN_PER;
    uint add = sums[block];
    for (uint i = 0u; i < SCAN_PER; i++) {
        if (base + i < C.count) {
            data[base + i] += add;
        }
    }
}
