#version 450
// Fixed-step ray marching of the trilinear isosurface (`render.method = "fixed-step"`).
// Mirrors `reference::fixed_step` (f64) step for step:
//   1. clip the ray to the grid box: [t0, t1], t0 >= 0 (the eye may be inside);
//   2. take `steps` samples at t_i = t0 + (t1 - t0) * i / (steps - 1), i = 0 .. steps-1;
//   3. at the first change of the inside predicate between samples i-1 and i, refine:
//      REFINE_BISECTIONS bisections keeping the predicate change bracketed, then one secant
//      step on the final bracket;
//   4. normal: analytic gradient of the trilinear interpolant at the hit.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = RAY_GROUP, local_size_y = RAY_GROUP) in;  // build.rs

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
layout(binding = 1) uniform sampler3D u_grid;
layout(std430, binding = 2) writeonly buffer Out { Pixel pixels[]; };
layout(std430, binding = 3) readonly buffer Colormap { vec4 colormap[256]; };
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;

#include "field.glsl"
#include "shade.glsl"
#include "camera.glsl"
#include "clip.glsl"

const int REFINE_BISECTIONS = 8;

void main() {
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= P.image.w || local.y >= band.rows) return;
    uvec2 px = uvec2(local.x, local.y + band.row_offset) * P.image.z;
    vec3 o;
    vec3 d;
    camera_ray(px, o, d);

    Pixel r;
    r.rgba = P.background;
    r.normal = vec3(0.0);
    r.depth = 1.0 / 0.0;
    r.position = vec3(0.0);
    r.steps = 0.0;
    r.cell = ivec3(-1);
    r.crossings = -1;

    float t0, t1;
    if (clip_box(o, d, t0, t1) && clip_interval(o, d, t0, t1)) {
        uint n = P.method.z;
        CellCache cache = cache_empty();
        float ta = t0;
        float fa = field_cached(cache, to_grid(o + d * t0));
        bool ina = is_inside(fa);
        uint count = 1u;
        // The march only finds the first interval [ta, tb] where the predicate changes; the
        // refinement and the hit's attributes come after the loop on purpose: llvmpipe runs a
        // branch's code for every lane under a mask, so code in the loop's body costs on every
        // sample of every ray.
        bool crossed = false;
        float tb = t0;
        float fb = fa;
        for (uint i = 1u; i < n; i++) {
            tb = t0 + (t1 - t0) * (float(i) / float(n - 1u));
            fb = field_cached(cache, to_grid(o + d * tb));
            count++;
            if (is_inside(fb) != ina) {
                crossed = true;
                break;
            }
            ta = tb;
            fa = fb;
        }
        if (crossed) {
            // Refine: keep [ta, tb] bracketing the change of the predicate.
            for (int k = 0; k < REFINE_BISECTIONS; k++) {
                float tm = 0.5 * (ta + tb);
                float fm = field_cached(cache, to_grid(o + d * tm));
                if (is_inside(fm) == ina) { ta = tm; fa = fm; } else { tb = tm; fb = fm; }
            }
            float s = fb != fa ? clamp((P.surface.x - fa) / (fb - fa), 0.0, 1.0) : 0.5;
            float th = ta + (tb - ta) * s;
            vec3 hit = o + d * th;
            vec3 u = to_grid(hit);
            r.depth = th;
            r.position = hit;
            r.cell = cell_of(u);
            r.normal = scene_normal(u, normal_at(u, -d));
            r.rgba = vec4(shade(r.normal, d, th, float(count), u, r.cell), 1.0);
        }
        r.steps = float(count);
    }
    pixels[local.y * P.image.w + local.x] = r;
}
