#version 450
// Layout test (tests/it/layout.rs): copies every member of RenderParams back as raw bits, and
// writes a Pixel whose float/int members hold 1, 2, 3, ... in declaration order, so the Rust
// mirrors of both structs can be checked against what GLSL sees.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = 1) in;

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(std430, binding = 1) buffer Bits { uvec4 bits[]; };
layout(std430, binding = 2) buffer Pixels { Pixel pixels[]; };

void main() {
    bits[0] = floatBitsToUint(P.eye);
    bits[1] = floatBitsToUint(P.forward);
    bits[2] = floatBitsToUint(P.right);
    bits[3] = floatBitsToUint(P.up);
    bits[4] = floatBitsToUint(P.box_min);
    bits[5] = floatBitsToUint(P.box_max);
    bits[6] = floatBitsToUint(P.inv_spacing);
    bits[7] = floatBitsToUint(P.background);
    bits[8] = floatBitsToUint(P.color);
    bits[9] = uvec4(P.dims);
    bits[10] = P.image;
    bits[11] = P.method;
    bits[12] = floatBitsToUint(P.surface);
    bits[13] = floatBitsToUint(P.debug);
    bits[14] = floatBitsToUint(P.eye_grid);
    bits[15] = P.analytic;
    bits[16] = P.view;
    for (int i = 0; i < CLIP_PLANES; i++) bits[17 + i] = floatBitsToUint(P.clip[i]);
    for (int i = 0; i < SURFACES / 4; i++)
        bits[17 + CLIP_PLANES + i] = floatBitsToUint(P.thresholds[i]);
    for (int i = 0; i < SURFACES; i++)
        bits[17 + CLIP_PLANES + SURFACES / 4 + i] = floatBitsToUint(P.surface_color[i]);

    Pixel p;
    p.rgba = vec4(1.0, 2.0, 3.0, 4.0);
    p.normal = vec3(5.0, 6.0, 7.0);
    p.depth = 8.0;
    p.position = vec3(9.0, 10.0, 11.0);
    p.steps = 12.0;
    p.cell = ivec3(13, 14, 15);
    p.crossings = 16;
    p.surface = 17;
    p.value = 18.0;
    p.pad0 = 19u;
    p.pad1 = 20u;
    pixels[1] = p;
}
