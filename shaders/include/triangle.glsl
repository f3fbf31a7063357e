// Ray-triangle intersection for the mesh render (`render.method = "mesh"`). Mirrors
// `reference::mesh::intersect` (f64).
//
// Watertight test of Woop, Benthin and Wald (JCGT 2013): the ray is sheared so that it runs
// along +z through the origin, the triangle is projected onto that frame, and the three 2D edge
// functions U, V, W decide coverage. An edge shared by two triangles gives edge functions that
// are exact negatives of each other (same products, operands swapped), so a ray through a
// shared edge hits at least one of the two triangles: a closed mesh shows no cracks. `precise`
// keeps the compiler from fusing the products into FMAs, which would break that symmetry.

// The shear of the ray o + t d, computed once per ray.
struct RayShear {
    ivec3 k;     // kx, ky, kz: kz the dominant axis of d; (kx, ky) keep the winding
    vec3 s;      // Sx, Sy, Sz
};

RayShear ray_shear(vec3 d) {
    vec3 a = abs(d);
    int kz = a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < 0.0) { int tmp = kx; kx = ky; ky = tmp; }
    RayShear r;
    r.k = ivec3(kx, ky, kz);
    r.s = vec3(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    return r;
}

// Intersects the ray o + t d (shear `sh`) with triangle (A, B, C). On a hit returns true with the
// distance t (in units of |d|) and the barycentric weights of A, B, C. Hits at t <= 0 are
// returned too (callers want t > 0). A triangle seen edge-on (zero projected area) is missed.
bool intersect_triangle(vec3 o, RayShear sh, vec3 A, vec3 B, vec3 C, out float t, out vec3 bary) {
    t = 0.0;
    bary = vec3(0.0);
    vec3 a = A - o;
    vec3 b = B - o;
    vec3 c = C - o;
    precise float ax = a[sh.k.x] - sh.s.x * a[sh.k.z];
    precise float ay = a[sh.k.y] - sh.s.y * a[sh.k.z];
    precise float bx = b[sh.k.x] - sh.s.x * b[sh.k.z];
    precise float by = b[sh.k.y] - sh.s.y * b[sh.k.z];
    precise float cx = c[sh.k.x] - sh.s.x * c[sh.k.z];
    precise float cy = c[sh.k.y] - sh.s.y * c[sh.k.z];
    precise float u = cx * by - cy * bx;
    precise float v = ax * cy - ay * cx;
    precise float w = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
    float det = u + v + w;
    if (det == 0.0) return false;
    float az = sh.s.z * a[sh.k.z];
    float bz = sh.s.z * b[sh.k.z];
    float cz = sh.s.z * c[sh.k.z];
    t = (u * az + v * bz + w * cz) / det;
    bary = vec3(u, v, w) / det;
    return true;
}

// The barycentric weights of the point where the ray meets the plane of (A, B, C), clamped to
// the triangle (for a ray that grazes an edge of the triangle it was found to hit).
vec3 plane_barycentrics(vec3 o, RayShear sh, vec3 A, vec3 B, vec3 C) {
    vec3 a = A - o;
    vec3 b = B - o;
    vec3 c = C - o;
    float ax = a[sh.k.x] - sh.s.x * a[sh.k.z];
    float ay = a[sh.k.y] - sh.s.y * a[sh.k.z];
    float bx = b[sh.k.x] - sh.s.x * b[sh.k.z];
    float by = b[sh.k.y] - sh.s.y * b[sh.k.z];
    float cx = c[sh.k.x] - sh.s.x * c[sh.k.z];
    float cy = c[sh.k.y] - sh.s.y * c[sh.k.z];
    vec3 w = vec3(cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax);
    float det = w.x + w.y + w.z;
    if (det == 0.0) return vec3(1.0 / 3.0);
    w = max(w / det, vec3(0.0));
    float sum = w.x + w.y + w.z;
    return sum > 0.0 ? w / sum : vec3(1.0 / 3.0);
}
