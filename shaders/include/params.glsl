// Per-render constants; mirrors `render::params::RenderParams` (std140, vec4 members only;
// layout tested on the GPU).
struct RenderParams {
    vec4 eye;          // xyz: camera position
    vec4 forward;      // xyz: unit view direction
    vec4 right;        // xyz: right * tan(fov/2) * aspect
    vec4 up;           // xyz: up' * tan(fov/2)
    vec4 box_min;      // xyz: world position of grid point (0,0,0)
    vec4 box_max;      // xyz: world position of the last grid point
    vec4 inv_spacing;  // xyz: cells per world unit along each axis
    vec4 background;   // linear RGBA of misses
    vec4 color;        // rgb: surface colour
    ivec4 dims;        // xyz: grid points per axis
    uvec4 image;       // x: width, y: height of the image (rays); z: stride s >= 1 and
                       // w: width of the picture drawn, ceil(width / s): picture pixel
                       // (i, j) is image pixel (s i, s j) (s = 1: the whole image)
    uvec4 method;      // x: method (0 fixed-step, 1 analytic, 2 mesh), y: shading, z: steps, w: newton steps
    vec4 surface;      // x: the exact inside threshold t (v < t, or v > t, equals the f64
                       // comparison with the isovalue: render::params::surface_threshold),
                       // y: +1 if below is inside, -1 if above; z, w: depth-shading near, far
    vec4 debug;        // x: step count that maps to the top of the colormap
    vec4 eye_grid;     // xyz: the eye in index space, (eye - box_min) / spacing, computed in f64
    uvec4 analytic;    // x: which crossing is the hit (>= 1), y: 1 = empty-space skipping,
                       // z: brick size in cells (the min/max grid of the skipping),
                       // w: 1 = count every crossing
    uvec4 view;        // x: 1 = orthographic camera, y: normals (NORMALS_TRILINEAR or
                       // NORMALS_SMOOTH), z: clip planes in use, w: surfaces (>= 1)
    ivec4 block_lo;    // xyz: first cell this process traces (an MPI rank's block; 0: all)
    ivec4 block_hi;    // xyz: one past the last cell it traces
    ivec4 block_origin;  // xyz: the grid point in texel (0,0,0) of u_grid
    vec4 clip[CLIP_PLANES];  // xyz: normal, w: offset, in the grid's frame; each removes
                             // dot(normal, p) > offset
    vec4 thresholds[SURFACES / 4];   // surface k's inside threshold (as surface.x, which is
                                     // surface 0's) is thresholds[k / 4][k % 4]
    vec4 surface_color[SURFACES];    // rgb: surface k's colour (surface_color[0] == color)
};

// The method codes (METHOD_FIXED_STEP, METHOD_ANALYTIC, METHOD_MESH) and shading codes
// (SHADE_LAMBERT, SHADE_NORMAL, SHADE_DEPTH, SHADE_STEPS, SHADE_CELLS, SHADE_SOLID) are
// #defines from build.rs's table of shared constants (Rust: `isoview::shaders::consts`).
