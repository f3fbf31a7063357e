// Shading modes of `render.shading`. Mirrors `render::shade` (the CPU side used by references).
// Needs: `RenderParams P` and `vec4 colormap[256]` (the steps heat map) declared before inclusion.

const float AMBIENT = 0.15;
const float CELL_BORDER = 0.03;  // width of cell borders in `cells` shading, in cells

// Headlight: light from the eye, two-sided so surfaces seen from inside are lit too.
float lambert(vec3 n, vec3 dir) {
    return AMBIENT + (1.0 - AMBIENT) * abs(dot(n, dir));
}

vec3 heat(float x) {
    return colormap[uint(clamp(x, 0.0, 1.0) * 255.0 + 0.5)].rgb;
}

// Colour of a hit: unit normal n, unit ray direction dir, distance depth, `steps` visited,
// grid coordinates u of the hit and its cell, the surface's colour `base`.
vec3 shade(vec3 n, vec3 dir, float depth, float steps, vec3 u, ivec3 cell, vec3 base) {
    switch (P.shading) {
    case SHADE_NORMAL:
        return n * 0.5 + 0.5;
    case SHADE_DEPTH:
        return vec3(1.0 - clamp((depth - P.depth_near) / (P.depth_far - P.depth_near), 0.0, 1.0));
    case SHADE_STEPS:
        return heat(steps / P.steps_scale);
    case SHADE_CELLS: {
        vec3 f = u - vec3(cell);
#ifdef INTERP_NEAREST
        // A checker over voxels (cell: the inside voxel's point, at its centre); every hit lies
        // on a voxel wall along the face's own axis, which the border test leaves out.
        f += 0.5;
        vec3 edge = min(f, 1.0 - f);
        vec3 an = abs(n);
        int axis = an.x >= an.y && an.x >= an.z ? 0 : (an.y >= an.z ? 1 : 2);
        edge[axis] = 1.0 / 0.0;
#else
        vec3 edge = min(f, 1.0 - f);
#endif
        float tone = ((cell.x + cell.y + cell.z) & 1) == 0 ? 1.0 : 0.6;
        if (min(edge.x, min(edge.y, edge.z)) < CELL_BORDER) tone *= 0.25;
        return base * tone * lambert(n, dir);
    }
    case SHADE_SOLID:
        return base;
    default:
        return base * lambert(n, dir);
    }
}
