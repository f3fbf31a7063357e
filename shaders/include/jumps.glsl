// Whether a ray's brick jumps are exact (bricks.glsl's jumps, entries/compact.comp's sort).

#ifndef JUMPS_GLSL
#define JUMPS_GLSL

// Whether the plane t's of the ray o + t d (index space) are strictly increasing along each
// axis, so that jumps over bricks land exactly where the cell-by-cell walk is (leave_brick,
// land_at): plane numerators c - o distinct and ordered (|o| < 2^20), quotients finite and
// normal (2^-90 < |d| < 2^90 where d != 0). Always true for cameras within a million cells of
// the grid; other rays walk cell by cell.
bool jumps_exact(vec3 o, vec3 d) {
    bool exact = all(lessThan(abs(o), vec3(1048576.0)));
    for (int a = 0; a < 3; a++) {
        float m = abs(d[a]);
        if (m != 0.0 && !(m > 8.0779356694631609e-28 && m < 1.2379400392853803e27)) exact = false;
    }
    return exact;
}

#endif
