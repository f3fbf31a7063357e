// One output pixel; mirrors `frame::Pixel` (std430, 80 bytes; layout tested on the GPU).
struct Pixel {
    vec4 rgba;      // shaded colour, A = coverage
    vec3 normal;    // world-space unit normal, inside -> outside
    float depth;    // distance along the unit ray; +inf on a miss
    vec3 position;  // world-space hit
    float steps;    // samples (fixed-step) or cells (analytic) visited
    ivec3 cell;     // hit cell, -1 on a miss
    int crossings;  // isovalue crossings inside the box, -1 where not counted
    int surface;    // index of the surface hit with several isovalues; -1 on a miss or with one
    float value;    // the quantity `[color] by` colours with at the hit; NaN on a miss or without
    uint pad0;      // std430 pads the struct to 80 bytes
    uint pad1;
};
