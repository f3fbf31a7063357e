// One output pixel; mirrors `frame::Pixel` (std430, 64 bytes; layout tested on the GPU).
struct Pixel {
    vec4 rgba;      // shaded colour, A = coverage
    vec3 normal;    // world-space unit normal, inside -> outside
    float depth;    // distance along the unit ray; +inf on a miss
    vec3 position;  // world-space hit
    float steps;    // samples (fixed-step) or cells (analytic) visited
    ivec3 cell;     // hit cell, -1 on a miss
    int crossings;  // isovalue crossings inside the box, -1 where not counted
};
