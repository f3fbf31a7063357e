#version 450
// Extraction pass `scan`: in-place exclusive prefix sum of blocks of 1024 u32 (256 invocations
// x 4 elements), writing each block's total to `sums`. Scanning `sums` the same way and adding
// it back (`scan_add.comp`) gives the scan of the whole array, level by level.
//
// Within a block: each invocation scans its 4 elements serially, the 256 totals are scanned in
// shared memory (Hillis-Steele, 8 steps, double buffered), and each invocation adds the total of
// those before it. Integer adds, so the result does not depend on the order of the work.

layout(local_size_x = 256) in;

layout(std430, binding = 0) buffer Data { uint data[]; };
layout(std430, binding = 1) buffer Sums { uint sums[]; };

layout(push_constant) uniform Push {
    uint groups_x;  // workgroups along x (blocks spread over x and y)
    uint count;     // elements in `data`
} C;

shared uint sh[2][256];

void main() {
    uint block = gl_WorkGroupID.x + gl_WorkGroupID.y * C.groups_x;
    uint lid = gl_LocalInvocationID.x;
    uint base = block * 1024u + lid * 4u;
    uint v[4];
    uint total = 0u;
    for (uint i = 0u; i < 4u; i++) {
        uint x = base + i < C.count ? data[base + i] : 0u;
        v[i] = total;
        total += x;
    }
    // Inclusive scan of the invocations' totals.
    uint src = 0u;
    sh[src][lid] = total;
    barrier();
    for (uint step = 1u; step < 256u; step <<= 1u) {
        uint x = sh[src][lid];
        if (lid >= step) {
            x += sh[src][lid - step];
        }
        sh[1u - src][lid] = x;
        src = 1u - src;
        barrier();
    }
    uint before = lid > 0u ? sh[src][lid - 1u] : 0u;
    for (uint i = 0u; i < 4u; i++) {
        if (base + i < C.count) {
            data[base + i] = before + v[i];
        }
    }
    if (lid == 255u) {
        sums[block] = sh[src][255];
    }
}
