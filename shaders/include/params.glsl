// Per-render constants; mirrors `render::params::RenderParams` (std140: each vec3 is followed
// by a scalar that fills its 16 bytes, scalars come in fours; offsets checked by SPIR-V
// reflection and a GPU round trip in tests/it/gpu/layout.rs). The `padN` members are never read.
struct RenderParams {
    // Camera (Rust: `camera::Camera`).
    vec3 eye;          float pad0;   // camera position
    vec3 forward;      float pad1;   // unit view direction
    vec3 right;        float pad2;   // right * tan(fov/2) * aspect
    vec3 up;           float pad3;   // up' * tan(fov/2)
    // Grid.
    vec3 box_min;      float pad4;   // world position of grid point (0,0,0)
    vec3 box_max;      float pad5;   // world position of the last grid point
    vec3 inv_spacing;  float pad6;   // cells per world unit along each axis
    vec3 eye_grid;     float pad7;   // the eye in index space, (eye - box_min) / spacing (f64)
    ivec3 dims;        int pad8;     // grid points per axis
    ivec3 block_lo;    int pad9;     // first cell this process traces (an MPI rank's block; 0: all)
    ivec3 block_hi;    int pad10;    // one past the last cell it traces
    ivec3 block_origin;  int pad11;  // the grid point in texel (0,0,0) of u_grid
    // Colours.
    vec4 background;                 // linear RGBA of misses
    vec3 color;        float pad12;  // surface 0's linear RGB (== surface_color[0].rgb)
    // Image: width x height rays; picture pixel (i, j) is image pixel (stride i, stride j), and
    // the picture drawn is picture_width = ceil(width / stride) wide (stride 1: the whole image).
    uint width;
    uint height;
    uint stride;
    uint picture_width;
    // Method and shading.
    uint shading;       // SHADE_*
    uint steps;         // fixed-step samples per ray
    uint newton_steps;  // analytic: Newton steps refining a root
    uint normals;       // NORMALS_TRILINEAR or NORMALS_SMOOTH
    float threshold;    // the exact inside threshold t of surface 0 (v < t, or v > t, equals the
                        // f64 comparison with the isovalue: render::params::surface_threshold)
    float inside_sign;  // +1 if below is inside, -1 if above
    float depth_near;   // depth shading: the distances shown white ...
    float depth_far;    // ... and black
    float steps_scale;  // step count that maps to the top of the `steps` colormap
    uint crossing;      // analytic: which crossing is the hit (>= 1)
    uint skip;          // analytic: 1 = empty-space skipping over the min/max bricks
    uint count_crossings;  // 1 = count every crossing (the `crossings` channel)
    uint orthographic;  // 1 = orthographic camera
    uint clip_count;    // clip planes in use
    uint surfaces;      // surfaces (>= 1)
    uint pad13;
    vec4 clip[CLIP_PLANES];  // xyz: normal, w: offset, in the grid's frame; each removes
                             // dot(normal, p) > offset
    vec4 thresholds[SURFACES / 4];   // surface k's inside threshold (as `threshold`, which is
                                     // surface 0's) is thresholds[k / 4][k % 4]
    vec4 surface_color[SURFACES];    // rgb: surface k's colour (surface_color[0].rgb == color)
};

// The shading codes (SHADE_LAMBERT, SHADE_NORMAL, SHADE_DEPTH, SHADE_STEPS, SHADE_CELLS,
// SHADE_SOLID) and normals codes are #defines from build.rs's table of shared constants (Rust:
// `isoview::shaders::consts`).
