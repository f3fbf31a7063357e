#version 450
// Extraction pass `scan`: in-place exclusive prefix sum of blocks of 1024 u32 (64 invocations
// x 16 elements), writing each block's total to `sums`. Scanning `sums` the same way and adding
// it back (`scan_add.comp`) gives the scan of the whole array, level by level.
//
// Within a block: each invocation scans its 16 elements serially, the 64 totals are scanned in
// shared memory (Hillis-Steele, 6 steps, double buffered), and each invocation adds the total of
// those before it. (Few invocations with more serial work each: barriers are what costs most on
// lavapipe, and 64 invocations still fill a GPU's workgroup.) Integer adds, so the result does not depend on the order of the work.

layout(local_size_x = EXTRACT_GROUP) in;  // build.rs

layout(std430, binding = 0) buffer Data { uint data[]; };
layout(std430, binding = 1) buffer Sums { uint sums[]; };

layout(push_constant) uniform Push {
    uint groups_x;  // workgroups along x (blocks spread over x and y)
    uint count;     // elements in `data`
} C;

const uint PER = SCAN_PER;  // build.rs
const uint N = uint(EXTRACT_GROUP);

shared uint sh[2][N];

void main() {
    uint block = gl_WorkGroupID.x + gl_WorkGroupID.y * C.groups_x;
    uint lid = gl_LocalInvocationID.x;
    uint base = block * SCAN_BLOCK + lid * PER;
    uint v[PER];
    uint total = 0u;
    for (uint i = 0u; i < PER; i++) {
        uint x = base + i < C.count ? data[base + i] : 0u;
        v[i] = total;
        total += x;
    }
    // Inclusive scan of the invocations' totals.
    uint src = 0u;
    sh[src][lid] = total;
    barrier();
    for (uint step = 1u; step < N; step <<= 1u) {
        uint x = sh[src][lid];
        if (lid >= step) {
            x += sh[src][lid - step];
        }
        sh[1u - src][lid] = x;
        src = 1u - src;
        barrier();
    }
    uint before = lid > 0u ? sh[src][lid - 1u] : 0u;
    for (uint i = 0u; i < PER; i++) {
        if (base + i < C.count) {
            data[base + i] = before + v[i];
        }
    }
    if (lid == N - 1u) {
        sums[block] = sh[src][N - 1u];
    }
}
