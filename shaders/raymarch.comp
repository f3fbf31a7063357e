#version 450
// Fixed-step ray marching of the isosurface (`render.method = "fixed-step"`), of the trilinear
// interpolant or, in the variants that define INTERP_BSPLINE, INTERP_CATMULL_ROM,
// INTERP_NEAREST or INTERP_DEVICE (build.rs), of that one (field.glsl's `field_cached`).
// Mirrors `reference::fixed_step` (f64, `march_sampled`) step for step:
//   1. clip the ray to the grid box: [t0, t1], t0 >= 0 (the eye may be inside);
//   2. take `steps` samples at t_i = t0 + (t1 - t0) * i / (steps - 1), i = 0 .. steps-1;
//   3. at the first change of the inside predicate between samples i-1 and i, refine:
//      REFINE_BISECTIONS bisections keeping the predicate change bracketed, then one secant
//      step on the final bracket;
//   4. normal: analytic gradient of the interpolant at the hit (device: central differences of
//      its lookups; nearest: the face between the voxels of the refined bracket's ends, and
//      `cell` the inside voxel's point).
// Missing data (field.nan = "empty"): a sample whose cell is missing (field.glsl's
// cell_missing) has no inside state, and a step with such a sample at either end has no
// crossing; a bisection midpoint in a missing cell moves the far end of the bracket (keeping
// its value), and a surface whose refined point lies in a missing cell is not hit there: when
// no other surface is, the march goes on from the step's far sample.

#extension GL_GOOGLE_include_directive : require

#extension GL_EXT_control_flow_attributes : require

layout(local_size_x = RAY_GROUP, local_size_y = RAY_GROUP) in;  // build.rs

// The cubic variants' loops over a cell's 64 samples unrolled, as tricubic.comp's (which says
// why): a loop's back-edges count towards llvmpipe's cap (MARCH_SAMPLE below), 128 a cell.
#define CUBIC_UNROLL [[unroll]]

#include "params.glsl"
#include "pixel.glsl"

layout(std140, binding = 0) uniform Params { RenderParams P; };
#ifdef GRID_POOL
// `field.residency = "active"` (render/pool.rs): the grid's resident bricks, one slot of
// (BRICK + 1 + 2 POOL_APRON)^3 points each, and the page table of every brick.
layout(std430, binding = 1) readonly buffer Pool { float pool[]; };
layout(std430, binding = 5) readonly buffer Pages { uint pages[]; };
#elif defined(GRID_BUFFER)
// The whole grid's points, x fastest (a copy of the grid image; render/rays.rs): trilinear's
// default, the same values as the image's with a fraction of the instructions on llvmpipe.
layout(std430, binding = 1) readonly buffer Grid { float grid[]; };
#else
layout(binding = 1) uniform sampler3D u_grid;
#endif
layout(std430, binding = 2) writeonly buffer Out { Pixel pixels[]; };
layout(std430, binding = 3) readonly buffer Colormap { vec4 colormap[256]; };
#ifdef GRID_POOL
// The brick min/max grid: a brick not in the pool reads as its minimum (field.glsl).
layout(std430, binding = 4) readonly buffer Bricks { vec2 bricks[]; };
#endif
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;

// A march of more samples than one loop can take on llvmpipe (passes::raymarch::LOOP_STEPS):
// the samples are taken MARCH_UNROLL at a time, written out. A specialization constant, so that
// the usual march carries none of that code (17 copies of a sample cost llvmpipe 1.8x the
// time even where they never run).
layout(constant_id = 0) const bool LONG_MARCH = false;
// The surfaces (RenderParams.surfaces), known when the pipeline is built: field.glsl's
// inside_mask loops over them unrolled, one test a surface and no back-edge a sample (its loop
// over P.surfaces cost one, and two thirds of llvmpipe's cap went to such loops).
layout(constant_id = 1) const uint SURFACE_COUNT = 1u;
#define SURFACES_TESTED SURFACE_COUNT

#include "field.glsl"
#include "shade.glsl"
#include "camera.glsl"
#include "clip.glsl"

const int REFINE_BISECTIONS = 8;

// Sample i of the march (tb, fb; `flipped`: the surfaces whose predicate changes from ta's),
// unless the march is past its last sample or has found its step; where nothing changes, the
// step's far end becomes its near one and i moves on.
#define MARCH_SAMPLE                                                \
    if (i < n && flipped == 0u) {                                   \
        tb = t0 + (t1 - t0) * (float(i) / float(n - 1u));           \
        fb = field_cached(cache, to_grid(o + d * tb));              \
        count++;                                                    \
        uint inb = inside_mask(fb);                                 \
        flipped = gap || cache.missing ? 0u : inb ^ ina;            \
        if (flipped == 0u) {                                        \
            ta = tb;                                                \
            fa = fb;                                                \
            ina = inb;                                              \
            gap = cache.missing;                                    \
            i++;                                                    \
        }                                                           \
    }
// MARCH_UNROLL (17) of them, written out: a loop, even one marked [[unroll]], is not unrolled
// by lavapipe's compiler here and its back-edges count.
#if MARCH_UNROLL != 17
#error "MARCH_BLOCK writes out MARCH_UNROLL samples"
#endif
#define MARCH_4 MARCH_SAMPLE MARCH_SAMPLE MARCH_SAMPLE MARCH_SAMPLE
#define MARCH_BLOCK MARCH_4 MARCH_4 MARCH_4 MARCH_4 MARCH_SAMPLE

void main() {
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= P.picture_width || local.y >= band.rows) return;
    uvec2 px = uvec2(local.x, local.y + band.row_offset) * P.stride;
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
    r.surface = -1;
    r.value = uintBitsToFloat(0x7fc00000u);  // NaN: no [color] value
    r.pad0 = 0u;
    r.pad1 = 0u;

    float t0, t1;
    if (clip_box(o, d, t0, t1) && clip_interval(o, d, t0, t1)) {
        uint n = P.steps;
        CellCache cache = cache_empty();
        uint surfaces = P.surfaces;
        float ta = t0;
        float fa = field_cached(cache, to_grid(o + d * t0));
        uint ina = inside_mask(fa);
        bool gap = cache.missing;  // the sample at ta is missing
        uint count = 1u;
        // The sample loop only finds the first interval [ta, tb] where the predicate of any
        // surface changes; the refinement and the hit's attributes come after it on purpose:
        // llvmpipe runs a branch's code for every lane under a mask, so code in the loop's
        // body costs on every sample of every ray.
        float th = uintBitsToFloat(0x7f800000u);
        uint hit_surface = 0u;
#ifdef INTERP_NEAREST
        // The hit's refined bracket and whether its near end is inside: its voxel face.
        float ha = 0.0, hb = 0.0;
        bool h_in = false;
#endif
        uint i = 1u;
        // Once per crossing step: more than once only where every crossing found fell in a
        // missing cell.
        for (;;) {
            uint flipped = 0u;  // bit k: surface k's predicate changes in [ta, tb]
            float tb = t0;
            float fb = fa;
            // One sample a back-edge, or with LONG_MARCH MARCH_UNROLL of them (build.rs: llvmpipe
            // ends an invocation's loops after 65,535 back-edges in all; the block has none):
            // the same samples in the same order either way.
            while (i < n && flipped == 0u) {
                if (LONG_MARCH) {
                    MARCH_BLOCK
                } else {
                    MARCH_SAMPLE
                }
            }
            if (flipped == 0u) break;
            // Each surface that changes in [ta, tb] refined alone (as if it were the only
            // one); the nearest kept, ties to the lower surface.
            for (uint k = 0u; k < surfaces; k++) {
                if ((flipped & (1u << k)) == 0u) continue;
                float thr = P.thresholds[k / 4u][k % 4u];
                bool in_k = inside_of(fa, thr);
                float a = ta, b = tb, va = fa, vb = fb;
                // Refine: keep [a, b] bracketing the change of the predicate.
                for (int j = 0; j < REFINE_BISECTIONS; j++) {
                    float tm = 0.5 * (a + b);
                    float fm = field_cached(cache, to_grid(o + d * tm));
                    if (cache.missing) {
                        b = tm;
                    } else if (inside_of(fm, thr) == in_k) {
                        a = tm;
                        va = fm;
                    } else {
                        b = tm;
                        vb = fm;
                    }
                }
                float s = vb != va ? clamp((thr - va) / (vb - va), 0.0, 1.0) : 0.5;
                float t = a + (b - a) * s;
                field_cached(cache, to_grid(o + d * t));
                if (t < th && !cache.missing) {
                    th = t;
                    hit_surface = k;
#ifdef INTERP_NEAREST
                    ha = a;
                    hb = b;
                    h_in = in_k;
#endif
                }
            }
            if (!isinf(th)) break;
            // Every crossing in [ta, tb] fell in a missing cell: march on from tb (whose cell is
            // not missing: the step had a crossing).
            ta = tb;
            fa = fb;
            ina = inside_mask(fb);
            gap = false;
            i++;
        }
        if (!isinf(th)) {
            vec3 hit = o + d * th;
            vec3 u = to_grid(hit);
            r.depth = th;
            r.position = hit;
#ifdef INTERP_NEAREST
            r.normal = voxel_face(to_grid(o + d * ha), to_grid(o + d * hb), h_in, -d, r.cell);
#else
            r.cell = cell_of(u);
            r.normal = scene_normal(u, r.cell, normal_at(u, -d));
#endif
            r.surface = surfaces > 1u ? int(hit_surface) : -1;
            r.rgba = vec4(shade(r.normal, d, th, float(count), u, r.cell,
                                P.surface_color[hit_surface].rgb), 1.0);
        }
        r.steps = float(count);
    }
    pixels[local.y * P.picture_width + local.x] = r;
}
