// THE missing-data rule (`field.nan = "empty"`; Rust: `field::interpolant::is_missing` and
// `cell_missing`, whose docs are the specification): a NaN or infinite sample is missing data,
// and a cell whose trilinear stencil (its 8 corners) holds one holds no surface. Tested with
// isnan/isinf explicitly: GLSL's min, max and comparisons with NaN are undefined, so no other
// test may stand in for this one. A finite grid never takes a branch of it.
#ifndef MISSING_GLSL
#define MISSING_GLSL

bool is_missing(float v) {
    return isnan(v) || isinf(v);
}

// A cell's corners as field.glsl's `Corners` holds them (the z = 0 face, the z = 1 face).
bool corners_missing(vec4 lo, vec4 hi) {
    return any(isnan(lo)) || any(isinf(lo)) || any(isnan(hi)) || any(isinf(hi));
}

#endif
