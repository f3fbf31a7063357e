#version 450
// Layout test (tests/it/gpu/layout.rs): copies every member of RenderParams back as raw bits, and
// writes a Pixel whose float/int members hold 1, 2, 3, ... in declaration order, so the Rust
// mirrors of both structs can be checked against what GLSL sees.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = 1) in;

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(std430, binding = 1) buffer Bits { uint bits[]; };
layout(std430, binding = 2) buffer Pixels { Pixel pixels[]; };

// Appends a member's bits at the next words: the members are written back to back in
// declaration order, so the output is the Rust layout only if GLSL puts each named member at
// the Rust offset and nothing between them.
uint at = 0u;
void put(uint v) { bits[at++] = v; }
void put(int v) { put(uint(v)); }
void put(float v) { put(floatBitsToUint(v)); }
void put(ivec3 v) { put(v.x); put(v.y); put(v.z); }
void put(vec3 v) { put(v.x); put(v.y); put(v.z); }
void put(vec4 v) { put(v.xyz); put(v.w); }

void main() {
    put(P.eye); put(P.pad0);
    put(P.forward); put(P.pad1);
    put(P.right); put(P.pad2);
    put(P.up); put(P.pad3);
    put(P.box_min); put(P.pad4);
    put(P.box_max); put(P.pad5);
    put(P.inv_spacing); put(P.pad6);
    put(P.eye_grid); put(P.pad7);
    put(P.dims); put(P.pad8);
    put(P.block_lo); put(P.pad9);
    put(P.block_hi); put(P.pad10);
    put(P.block_origin); put(P.pad11);
    put(P.background);
    put(P.color); put(P.pad12);
    put(P.width); put(P.height); put(P.stride); put(P.picture_width);
    put(P.shading); put(P.steps); put(P.newton_steps); put(P.normals);
    put(P.threshold); put(P.inside_sign); put(P.depth_near); put(P.depth_far);
    put(P.steps_scale); put(P.crossing); put(P.skip); put(P.count_crossings);
    put(P.orthographic); put(P.clip_count); put(P.surfaces); put(P.pad13);
    for (int i = 0; i < CLIP_PLANES; i++) put(P.clip[i]);
    for (int i = 0; i < SURFACES / 4; i++) put(P.thresholds[i]);
    for (int i = 0; i < SURFACES; i++) put(P.surface_color[i]);

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
