#version 450
// The field on an axis-aligned slicing plane (`isoview slice`), one invocation per pixel of a
// band of rows. Mirrors `slice::reference` (f64):
//   1. pixel (px, py) -> grid index coordinates: (px + 0.5) * cells_u / W along the plane's u
//      axis, (H - py - 0.5) * cells_v / H along v, the plane's own coordinate along its axis;
//   2. value = the interpolant there (interpolant.glsl: the f64 reference's arithmetic);
//   3. colour = a diverging colormap at 0.5 + 0.5 * s * (value - iso) / range (s = +1 when
//      below is inside: inside takes the low end), linearly interpolated between 256 entries;
//   4. contour lines: distance to the segments listed for the pixel's 8x8 tile, drawn with
//      a one-pixel box-filtered edge over the colour.

#extension GL_GOOGLE_include_directive : require

layout(local_size_x = SLICE_GROUP, local_size_y = SLICE_GROUP) in;  // build.rs

// Mirrors `passes::slice::SliceParams` (std140, vec4 members only).
struct SliceParams {
    uvec4 axes;   // x: world axis of u (right), y: world axis of v (up), z: the slicing axis
    ivec4 dims;   // xyz: grid points per axis
    uvec4 image;  // x: width, y: height, z: contour tiles per row
    vec4 plane;   // x: grid index coordinate of the plane along its axis, y: isovalue,
                  // z: +1 if below is inside, -1 if above, w: |value - iso| at the map's ends
    vec4 scale;   // x: grid cells along u per pixel, y: along v, z: contour half width (pixels)
    vec4 line;    // contour colour, linear RGBA (A: opacity)
};

// Mirrors `passes::slice::SlicePixel` (std430, 32 bytes).
struct SlicePixel {
    vec4 rgba;
    float value;
    float contour;
    float pad0;
    float pad1;
};

layout(std140, binding = 0) uniform Params { SliceParams P; };
layout(binding = 1) uniform sampler3D u_grid;
layout(std430, binding = 2) writeonly buffer Out { SlicePixel pixels[]; };
layout(std430, binding = 3) readonly buffer Colormap { vec4 colormap[256]; };
// Segments of tile t are tile_segments[tile_start[t] .. tile_start[t + 1]].
layout(std430, binding = 4) readonly buffer TileStart { uint tile_start[]; };
layout(std430, binding = 5) readonly buffer TileSegments { uint tile_segments[]; };
// Contour segments in pixel coordinates (x right, y down, pixel centres at +0.5): (x0, y0, x1, y1).
layout(std430, binding = 6) readonly buffer Segments { vec4 segments[]; };
layout(push_constant) uniform Band { uint row_offset; uint rows; } band;

const uint TILE = uint(SLICE_GROUP);

#include "missing.glsl"
#include "interpolant.glsl"

// The colour of a pixel with no data (`slice::reference::NO_DATA`).
const vec3 NO_DATA = vec3(0.2);

float grid_value(ivec3 p) {
    return texelFetch(u_grid, p, 0).r;
}

// The interpolant at grid index coordinates g (inside the box); NaN where g's cell is missing
// (missing.glsl): trilinear, or the variant's (build.rs `VARIANTS`: `INTERP_BSPLINE`,
// `INTERP_CATMULL_ROM` read the cell's 4x4x4 samples, clamped to the grid, missing when one
// is; `INTERP_NEAREST` the nearest corner's sample, missing when it is).
float field_value(vec3 g) {
    ivec3 c = clamp(ivec3(floor(g)), ivec3(0), P.dims.xyz - 2);
#ifdef INTERP_CUBIC
    Samples s;
    bool missing = false;
    for (int n = 0; n < 64; n++) {
        ivec3 p = clamp(c + ivec3(n & 3, (n >> 2) & 3, n >> 4) - 1, ivec3(0), P.dims.xyz - 1);
        s.s[n] = grid_value(p);
        missing = missing || is_missing(s.s[n]);
    }
    if (missing) return uintBitsToFloat(0x7fc00000u);
    return cubic_value(s, g - vec3(c));
#else
    float v[8];
    for (int n = 0; n < 8; n++) {
        v[n] = grid_value(c + ivec3(n & 1, (n >> 1) & 1, n >> 2));
    }
    Corners k = corners_of(v);
#ifdef INTERP_NEAREST
    float near = nearest_value(k, g - vec3(c));
    return is_missing(near) ? uintBitsToFloat(0x7fc00000u) : near;
#else
    if (corners_missing(k.lo, k.hi)) return uintBitsToFloat(0x7fc00000u);
    return interp_value(k, g - vec3(c));
#endif
#endif
}

vec4 colormap_at(float c) {
    float x = clamp(c, 0.0, 1.0) * 255.0;
    int i = min(int(x), 254);
    return mix(colormap[i], colormap[i + 1], x - float(i));
}

float segment_distance(vec2 p, vec4 s) {
    vec2 a = s.xy;
    vec2 ab = s.zw - s.xy;
    float len2 = dot(ab, ab);
    float t = len2 > 0.0 ? clamp(dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
    return length(p - (a + t * ab));
}

void main() {
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= P.image.x || local.y >= band.rows) return;
    uvec2 px = uvec2(local.x, local.y + band.row_offset);

    // Pixel centre -> grid index coordinates.
    vec3 g;
    g[P.axes.x] = (float(px.x) + 0.5) * P.scale.x;
    g[P.axes.y] = (float(P.image.y - px.y) - 0.5) * P.scale.y;
    g[P.axes.z] = P.plane.x;
    float value = field_value(g);

    // Colour, centred on the isovalue.
    vec4 colour = isnan(value)
        ? vec4(NO_DATA, 1.0)
        : colormap_at(0.5 + 0.5 * P.plane.z * (value - P.plane.y) / P.plane.w);

    // Contour lines of this tile.
    uint tile = (px.y / TILE) * P.image.z + px.x / TILE;
    vec2 centre = vec2(px) + 0.5;
    float coverage = 0.0;
    for (uint n = tile_start[tile]; n < tile_start[tile + 1u]; n++) {
        float d = segment_distance(centre, segments[tile_segments[n]]);
        coverage = max(coverage, clamp(P.scale.z + 0.5 - d, 0.0, 1.0));
    }

    SlicePixel r;
    r.rgba = vec4(mix(colour.rgb, P.line.rgb, coverage * P.line.a), 1.0);
    r.value = value;
    r.contour = coverage;
    r.pad0 = 0.0;
    r.pad1 = 0.0;
    pixels[local.y * P.image.x + local.x] = r;
}
