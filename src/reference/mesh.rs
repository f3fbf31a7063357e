//! The mesh render in f64, as `shaders/mesh_raster.comp` and `shaders/mesh_resolve.comp` do it:
//! for every pixel, every triangle whose widened screen box holds the pixel is tested against
//! the pixel's ray with the watertight ray-triangle test of Woop, Benthin and Wald (JCGT 2013);
//! the nearest hit at t > 0 wins, ties to the lower triangle id.
//!
//! Brute force over all triangles (no acceleration): it is a reference for tests, not a
//! renderer. Channels: Z = t, P = eye + t dir, N = vertex normals interpolated with the hit's
//! barycentric weights (the geometric normal where they cancel), cell = the grid cell holding P,
//! steps = triangles tested, crossings = triangles hit at t > 0 (-1 unless
//! `render.count_crossings`).

use glam::DVec3;

use super::field::{cell_of, to_grid};
use super::shade::{RayHit, Shader};
use crate::camera::Camera;
use crate::field::Grid;
use crate::frame::Pixel;
use crate::mesh::Mesh;
use crate::scene::Scene;
use crate::vocab::Clip;

/// A hit of a ray on a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Distance along the unit ray (may be <= 0: behind the eye).
    pub t: f64,
    /// Barycentric weights of the triangle's vertices a, b, c.
    pub bary: DVec3,
}

/// The shear that maps the ray `o + t d` onto the +z axis (Woop et al.).
#[derive(Clone, Copy, Debug)]
pub struct RayShear {
    k: [usize; 3],
    s: DVec3,
}

impl RayShear {
    pub fn new(d: DVec3) -> Self {
        let a = d.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        RayShear { k: [kx, ky, kz], s: DVec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]) }
    }

    /// The 2D position of eye-relative point `q` in the sheared frame (the ray at the origin).
    fn project(&self, q: DVec3) -> (f64, f64) {
        let [kx, ky, kz] = self.k;
        (q[kx] - self.s.x * q[kz], q[ky] - self.s.y * q[kz])
    }

    /// The three edge functions (U, V, W) of triangle (a, b, c) for the ray from `o`.
    fn edges(&self, o: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [(f64, f64); 3] {
        [self.project(a - o), self.project(b - o), self.project(c - o)]
    }
}

/// Intersects the ray `o + t d` (its shear `sh`) with triangle (a, b, c); edges count as inside;
/// a triangle seen edge-on is missed.
pub fn intersect(o: DVec3, sh: &RayShear, a: DVec3, b: DVec3, c: DVec3) -> Option<TriangleHit> {
    let [(ax, ay), (bx, by), (cx, cy)] = sh.edges(o, a, b, c);
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let kz = sh.k[2];
    let (az, bz, cz) = (sh.s.z * (a - o)[kz], sh.s.z * (b - o)[kz], sh.s.z * (c - o)[kz]);
    Some(TriangleHit { t: (u * az + v * bz + w * cz) / det, bary: DVec3::new(u, v, w) / det })
}

/// How close the ray passes to the boundary of triangle (a, b, c), as an angle in radians
/// (distance in the sheared plane over the depth): f32 arithmetic can only change a hit into a
/// miss, or the reverse, where this is tiny.
pub fn edge_margin(o: DVec3, sh: &RayShear, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let p = sh.edges(o, a, b, c);
    let depth = [a, b, c].iter().map(|v| (*v - o).length()).fold(0.0, f64::max).max(1e-30);
    let mut m = f64::INFINITY;
    for e in 0..3 {
        let (p0, p1) = (p[e], p[(e + 1) % 3]);
        let (ex, ey) = (p1.0 - p0.0, p1.1 - p0.1);
        let len2 = ex * ex + ey * ey;
        let s = if len2 > 0.0 { ((-p0.0 * ex - p0.1 * ey) / len2).clamp(0.0, 1.0) } else { 0.0 };
        let (dx, dy) = (p0.0 + s * ex, p0.1 + s * ey);
        m = m.min((dx * dx + dy * dy).sqrt());
    }
    m / depth
}

/// Continuous pixel coordinates of eye-relative point `q` at view depth `z > 0` (orthographic:
/// no division by depth).
fn to_pixel(cam: &Camera, q: DVec3, z: f64) -> (f64, f64) {
    let z = if cam.orthographic { 1.0 } else { z };
    let sx = q.dot(cam.right_scaled) / (cam.right_scaled.length_squared() * z);
    let sy = q.dot(cam.up_scaled) / (cam.up_scaled.length_squared() * z);
    ((sx + 1.0) * 0.5 * cam.width as f64 - 0.5, (1.0 - sy) * 0.5 * cam.height as f64 - 0.5)
}

/// The pixels `[x0, x1] x [y0, y1]` whose rays are tested against triangle (a, b, c): the
/// screen box of its part in front of the eye, widened by one pixel, None when it lies wholly
/// behind. That part's picture is the vertices in front, projected, and for each edge crossing
/// the eye's plane a way off the screen (its point on the plane, seen as a direction: the far
/// part of the edge runs off that way), so the box reaches the picture's edge in each such way,
/// both ways where the direction is within 1e-3 of square to the axis (so f32 and f64 decide
/// alike), the whole picture for an edge through the eye. Orthographic: every vertex projected.
/// `mesh_raster.comp` follows the same rule.
pub fn screen_box(cam: &Camera, a: DVec3, b: DVec3, c: DVec3) -> Option<[i64; 4]> {
    let (w, h) = (cam.width as f64, cam.height as f64);
    let q = [a - cam.eye, b - cam.eye, c - cam.eye];
    let z = q.map(|q| q.dot(cam.forward));
    if z.iter().all(|&z| z <= 0.0) {
        return None;
    }
    let full = [0, cam.width as i64 - 1, 0, cam.height as i64 - 1];
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for i in 0..3 {
        if z[i] > 0.0 || cam.orthographic {
            let p = to_pixel(cam, q[i], z[i]);
            lo = [lo[0].min(p.0), lo[1].min(p.1)];
            hi = [hi[0].max(p.0), hi[1].max(p.1)];
        }
        let j = (i + 1) % 3;
        if !cam.orthographic && (z[i] > 0.0) != (z[j] > 0.0) {
            let s = z[i] / (z[i] - z[j]);
            let c = q[i] + s * (q[j] - q[i]);
            let dir = [
                c.dot(cam.right_scaled) / cam.right_scaled.length_squared(),
                -(c.dot(cam.up_scaled) / cam.up_scaled.length_squared()),
            ];
            let tol = 1e-3 * (dir[0].abs() + dir[1].abs());
            for k in 0..2 {
                if dir[k] >= -tol {
                    hi[k] = f64::INFINITY;
                }
                if dir[k] <= tol {
                    lo[k] = f64::NEG_INFINITY;
                }
            }
        }
    }
    let lo = [lo[0].clamp(-2.0, w + 1.0), lo[1].clamp(-2.0, h + 1.0)];
    let hi = [hi[0].clamp(-2.0, w + 1.0), hi[1].clamp(-2.0, h + 1.0)];
    Some([
        full[0].max(lo[0].floor() as i64 - 1),
        full[1].min(hi[0].ceil() as i64 + 1),
        full[2].max(lo[1].floor() as i64 - 1),
        full[3].min(hi[1].ceil() as i64 + 1),
    ])
}

/// What the ray through one pixel meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshTrace {
    /// The nearest hit at t > 0 and its triangle.
    pub hit: Option<(u32, TriangleHit)>,
    /// Triangles whose screen box holds the pixel.
    pub tested: u32,
    /// Triangles hit at t > 0.
    pub hits: u32,
    /// Smallest [`edge_margin`] over the triangles tested (how close the ray came to changing
    /// any hit into a miss or back).
    pub margin: f64,
}

fn vertex(mesh: &Mesh, v: u32) -> DVec3 {
    DVec3::from(mesh.positions[v as usize].map(f64::from))
}

/// Traces the ray through pixel (px, py) against every triangle of `mesh`; `boxes` are the
/// triangles' [`screen_box`]es. Only hits in the interval that `clip` keeps count.
pub fn trace(
    mesh: &Mesh,
    cam: &Camera,
    clip: &Clip,
    boxes: &[Option<[i64; 4]>],
    px: u32,
    py: u32,
) -> MeshTrace {
    let (o, d) = cam.ray(px, py);
    let sh = RayShear::new(d);
    let kept = clip.interval(o, d);
    let (x, y) = (px as i64, py as i64);
    let mut out = MeshTrace { hit: None, tested: 0, hits: 0, margin: f64::INFINITY };
    for (t, b) in boxes.iter().enumerate() {
        let Some([x0, x1, y0, y1]) = *b else { continue };
        if x < x0 || x > x1 || y < y0 || y > y1 {
            continue;
        }
        out.tested += 1;
        let [a, b, c] = mesh.triangle(t).map(|v| vertex(mesh, v));
        out.margin = out.margin.min(edge_margin(o, &sh, a, b, c));
        if let Some(h) = intersect(o, &sh, a, b, c) {
            if h.t > 0.0 && kept.is_some_and(|(c0, c1)| h.t >= c0 && h.t <= c1) {
                out.hits += 1;
                if out.hit.map_or(true, |(_, best)| h.t < best.t) {
                    out.hit = Some((t as u32, h));
                }
            }
        }
    }
    out
}

/// The unit normal at barycentric weights `w` of triangle `tri`: interpolated vertex normals,
/// else the geometric normal, else `-dir`.
pub fn interpolated_normal(mesh: &Mesh, tri: u32, w: DVec3, dir: DVec3) -> DVec3 {
    let v = mesh.triangle(tri as usize);
    let w = w.max(DVec3::ZERO);
    let w = if w.element_sum() > 0.0 { w / w.element_sum() } else { DVec3::splat(1.0 / 3.0) };
    let n: DVec3 =
        (0..3).map(|i| w[i] * DVec3::from(mesh.normals[v[i] as usize].map(f64::from))).sum();
    if n.length() > 0.0 {
        return n.normalize();
    }
    let [a, b, c] = v.map(|i| vertex(mesh, i));
    let g = (b - a).cross(c - a);
    if g.length() > 0.0 {
        g.normalize()
    } else {
        -dir
    }
}

/// Renders `mesh` with `scene`'s camera and shading; `grid` gives the box and cells of the
/// `cell` channel and `cells` shading. Returns the pixels and each pixel's trace.
pub fn render(scene: &Scene, grid: &Grid, mesh: &Mesh) -> (Vec<Pixel>, Vec<MeshTrace>) {
    let cam = Camera::for_scene(scene);
    let clip = scene.clip.in_grid_frame(&scene.field.placement);
    let shader = Shader::new(scene, grid);
    let boxes: Vec<_> = (0..mesh.triangle_count())
        .map(|t| {
            let [a, b, c] = mesh.triangle(t).map(|v| vertex(mesh, v));
            screen_box(&cam, a, b, c)
        })
        .collect();
    let n = (scene.image.width * scene.image.height) as usize;
    let (mut pixels, mut traces) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for py in 0..scene.image.height {
        for px in 0..scene.image.width {
            let (origin, dir) = cam.ray(px, py);
            let tr = trace(mesh, &cam, &clip, &boxes, px, py);
            let hit = tr.hit.map(|(tri, h)| {
                let position = origin + dir * h.t;
                let u = to_grid(grid, position);
                RayHit {
                    t: h.t,
                    position,
                    normal: interpolated_normal(mesh, tri, h.bary, dir),
                    grid_coords: u,
                    cell: cell_of(grid, u),
                    surface: 0,
                }
            });
            let hit = hit.map(|h| super::shade::scene_normal(scene, grid, h));
            let background = scene.render.background;
            let crossings = if scene.render.count_crossings { tr.hits as i32 } else { -1 };
            let mut pixel = shader.pixel(hit.as_ref(), dir, tr.tested, crossings, background);
            pixel.place(&scene.field.placement);
            pixels.push(pixel);
            traces.push(tr);
        }
    }
    (pixels, traces)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_through_a_shared_edge_hits_one_of_its_triangles_and_t_is_exact() {
        // Two triangles of the square z = 1, |x|, |y| <= 1, split along x = y.
        let (a, b, c, d) = (
            DVec3::new(-1.0, -1.0, 1.0),
            DVec3::new(1.0, -1.0, 1.0),
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(-1.0, 1.0, 1.0),
        );
        let o = DVec3::ZERO;
        for dir in
            [DVec3::new(0.3, 0.3, 1.0), DVec3::new(0.0, 0.0, 1.0), DVec3::new(-0.2, 0.1, 1.0)]
        {
            let dir = dir.normalize();
            let sh = RayShear::new(dir);
            let h1 = intersect(o, &sh, a, b, c);
            let h2 = intersect(o, &sh, a, c, d);
            let h = h1.or(h2).expect("a ray through the square hits it");
            assert!((h.t - 1.0 / dir.z).abs() < 1e-12);
            assert!((h.bary.element_sum() - 1.0).abs() < 1e-12);
        }
        // Behind the eye: a hit with t < 0.
        let sh = RayShear::new(DVec3::new(0.0, 0.0, -1.0));
        assert!(intersect(o, &sh, a, b, c).unwrap().t < 0.0);
        // Outside.
        let sh = RayShear::new(DVec3::new(2.0, 0.0, 1.0).normalize());
        assert!(intersect(o, &sh, a, b, c).is_none());
    }
}
