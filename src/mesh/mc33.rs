//! Marching cubes with the topology of the trilinear interpolant (Chernyaev's MC33 cases),
//! computed per cell from the face and interior tests rather than read from a case table.
//!
//! Each cell's piece of surface is built in four steps. All decisions use the corner values
//! shifted and signed so that inside is positive, `g = iso - v` (`inside = below`) or `v - iso`
//! (`above`); `g > 0` is inside, `g = 0` outside, as everywhere.
//!
//! 1. **Face contours (asymptotic decider).** On each face, walked counter-clockwise about its
//!    outward normal (corners in [`FACES`] order), a crossed edge is *entering* (outside →
//!    inside) or *leaving*. A face with two crossings gets one segment, entering → leaving. A face
//!    with four (inside corners `a`, `c` on one diagonal, outside `b`, `d` on the other) is
//!    resolved by the saddle of its bilinear interpolant: the inside corners are joined iff
//!    `g_a g_c - g_b g_d > 0` (the saddle value is inside), and then each outside corner is cut
//!    off by a segment, else each inside corner is. The test depends on the face's four values
//!    only, so both cells sharing a face cut it alike: no cracks.
//! 2. **Contours.** Every crossed edge starts exactly one segment (on one of its two faces) and
//!    ends one (on the other), so the segments close into cycles, traced from the lowest
//!    unvisited edge number (Bourke's numbering, [`MC_EDGES`]). A contour runs with the inside
//!    on its right seen from outside the cube, which is the boundary orientation of a surface
//!    whose triangles face outward.
//! 3. **Regions (interior test).** The corners are grouped into the connected components of the
//!    inside set `{g > 0}` and of the outside set `{g <= 0}` of the trilinear interpolant *within
//!    the cell*. Boundary connections come from the edges and the face tests; connections
//!    through the interior from an exact sweep in z: the section at height `t` is bilinear, with
//!    corner values `g_q(t)` linear in `t` and saddle quantity
//!    `S(t) = g_0 g_3 - g_1 g_2` quadratic in `t`, so its topology only changes where some
//!    `g_q(t)` or `S(t)` has a root. One section is taken at `t = 0`, at `t = 1` and between
//!    consecutive roots; components of consecutive sections are joined through the vertical
//!    edges that stay inside (or outside) across. This decides every interior ambiguity of the
//!    MC33 cases (4.1.2, 6.1.2, 7.4.2, 10.1.2, 12.1.2, 13.5.2 tunnels) without a table.
//! 4. **Triangles.** A contour separates the inside component of the inside end of its edges
//!    from the outside component of the outside end. Contours bounding the same (inside
//!    component, outside component) pair bound one piece of surface: one contour is a disk,
//!    two are a tunnel. (The trilinear level set in a cell has no other piece; three or more
//!    contours on one pair, which only a degenerate tie could produce, are triangulated as
//!    disks, keeping the mesh closed.) No triangle edge other than a contour segment may join
//!    two vertices on a common face of the cell: such an edge lies in the face plane, where the
//!    neighbouring cell could draw it too. So a disk is a fan from its first vertex that has no
//!    such partner ([`disk`]), or, if none has, a fan around a vertex added at the contour's
//!    centre; a tunnel is a strip between its two contours ([`tube`]) whose few rungs that
//!    cannot avoid a common face are split by a vertex added near their midpoint.
//!
//! Vertices: those of marching cubes first (one per crossed lattice edge, same numbering),
//! then the added vertices, in cell order and, within a cell, in order of first use. Triangles:
//! cells in linear order; within a cell, pieces in the order of their first contour, contours
//! in the order traced. An added vertex sits at the mean of its contour's vertices (a centre)
//! or at the rung's midpoint moved a quarter of the way to the cell centre, with the field
//! normal there; it is not on the surface, only close to it.
//!
//! Checked against the trilinear interpolant itself (unit tests): on thousands of random cells
//! the components and Euler characteristic of each cell's patch equal those of the
//! interpolant's level set in the cell, tunnels included, where plain marching cubes is wrong
//! in about a fifth of the ambiguous cells.

use std::ops::Range;

use glam::DVec3;

use super::edges::{offset, EdgeLayers, Vertices};
use super::field::Field;
use super::slabs::{self, Part};
use super::tables::MC_EDGES;
use super::{Mesh, MeshError};
use crate::vocab::Inside;

/// Edge families: x, y, z (as marching cubes).
const FAMILIES: &[u8] = &[1, 2, 4];

/// The 6 faces of a cell, corners counter-clockwise about the outward normal: z = 0, z = 1,
/// y = 0, y = 1, x = 0, x = 1.
pub const FACES: [[u8; 4]; 6] =
    [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];

/// Bourke edge number of the cell edge between corners `a` and `b`.
fn edge_of(a: u8, b: u8) -> usize {
    let (lo, hi) = (a.min(b), a.max(b));
    let axis = (hi ^ lo).trailing_zeros() as u8;
    MC_EDGES
        .iter()
        .position(|&e| e == (lo, axis))
        .unwrap_or_else(|| unreachable!("corners {a} and {b} share no cell edge"))
}

/// Union-find over the 8 corners.
#[derive(Clone, Copy)]
struct Sets([u8; 8]);

impl Sets {
    fn new() -> Self {
        Sets([0, 1, 2, 3, 4, 5, 6, 7])
    }
    fn find(&mut self, mut x: u8) -> u8 {
        while self.0[x as usize] != x {
            x = self.0[x as usize];
        }
        x
    }
    fn union(&mut self, a: u8, b: u8) {
        let (ra, rb) = (self.find(a), self.find(b));
        self.0[ra.max(rb) as usize] = ra.min(rb);
    }
}

/// Whether the inside diagonal `(a, c)` of a face or section with outside diagonal `(b, d)` is
/// joined: the bilinear saddle is inside.
fn joined(ga: f64, gb: f64, gc: f64, gd: f64) -> bool {
    ga * gc - gb * gd > 0.0
}

/// The surface topology of one cell with inside-positive corner values `g`: contours as lists
/// of Bourke edge numbers, grouped into pieces (one contour: a disk; two: a tunnel).
pub(crate) fn cell_pieces(g: &[f64; 8]) -> Vec<Vec<Vec<usize>>> {
    let inside = |c: u8| g[c as usize] > 0.0;
    let mut regions = Sets::new();

    // 1. Face segments: next[e] = the edge after e along its contour.
    let mut next = [usize::MAX; 12];
    for face in &FACES {
        let c = |k: usize| face[k % 4];
        let ins: Vec<bool> = (0..4).map(|k| inside(c(k))).collect();
        let edge = |k: usize| edge_of(c(k), c(k + 1)); // edge from corner k to k+1
        let n_in = ins.iter().filter(|&&b| b).count();
        let ambiguous = n_in == 2 && ins[0] == ins[2];
        for k in 0..4 {
            if ins[k] == ins[(k + 1) % 4] {
                regions.union(c(k), c(k + 1));
            }
        }
        if ambiguous {
            let (a, b) = if ins[0] { (0, 1) } else { (1, 0) };
            let gv = |k: usize| g[c(k) as usize];
            let join_inside = joined(gv(a), gv(b), gv(a + 2), gv(b + 2));
            if join_inside {
                regions.union(c(a), c(a + 2));
            } else {
                regions.union(c(b), c(b + 2));
            }
            for k in 0..4 {
                if join_inside && !ins[k] {
                    // Cut off outside corner k: from edge (k, k+1) to edge (k-1, k).
                    next[edge(k)] = edge(k + 3);
                } else if !join_inside && ins[k] {
                    // Cut off inside corner k: from edge (k-1, k) to edge (k, k+1).
                    next[edge(k + 3)] = edge(k);
                }
            }
        } else if n_in != 0 && n_in != 4 {
            let entering = (0..4).find(|&k| !ins[k] && ins[(k + 1) % 4]);
            let leaving = (0..4).find(|&k| ins[k] && !ins[(k + 1) % 4]);
            if let (Some(en), Some(lv)) = (entering, leaving) {
                next[edge(en)] = edge(lv);
            }
        }
    }

    // 2. Contours.
    let mut contours: Vec<Vec<usize>> = Vec::new();
    let mut seen = [false; 12];
    for start in 0..12 {
        if next[start] == usize::MAX || seen[start] {
            continue;
        }
        let mut contour = Vec::new();
        let mut e = start;
        while !seen[e] {
            seen[e] = true;
            contour.push(e);
            e = next[e];
        }
        contours.push(contour);
    }

    // 3. Interior connections.
    sweep(g, &mut regions);

    // 4. Pieces: contours grouped by (inside component, outside component).
    let mut keys: Vec<(u8, u8)> = Vec::new();
    let mut pieces: Vec<Vec<Vec<usize>>> = Vec::new();
    for contour in contours {
        let (a, b) = MC_EDGES[contour[0]];
        let b = a | (1 << b);
        let (ci, co) = if inside(a) { (a, b) } else { (b, a) };
        let key = (regions.find(ci), regions.find(co));
        match keys.iter().position(|&k| k == key) {
            Some(p) => pieces[p].push(contour),
            None => {
                keys.push(key);
                pieces.push(vec![contour]);
            }
        }
    }
    // Degenerate: more than two contours on one pair; keep them as disks.
    let mut out = Vec::with_capacity(pieces.len());
    for piece in pieces {
        if piece.len() <= 2 {
            out.push(piece);
        } else {
            out.extend(piece.into_iter().map(|c| vec![c]));
        }
    }
    out
}

/// Joins the corners connected through the cell's interior, inside and outside alike, by
/// sweeping sections `z = t` (see the module docs).
fn sweep(g: &[f64; 8], regions: &mut Sets) {
    // Section corner q (x + 2y) at height t: a[q] + t * b[q].
    let a: [f64; 4] = [g[0], g[1], g[2], g[3]];
    let b: [f64; 4] = std::array::from_fn(|q| g[q + 4] - g[q]);
    let mut events: Vec<f64> = Vec::with_capacity(6);
    for q in 0..4 {
        if b[q] != 0.0 {
            events.push(-a[q] / b[q]);
        }
    }
    // S(t) = g0 g3 - g1 g2 = qa t² + qb t + qc.
    let qa = b[0] * b[3] - b[1] * b[2];
    let qb = a[0] * b[3] + a[3] * b[0] - a[1] * b[2] - a[2] * b[1];
    let qc = a[0] * a[3] - a[1] * a[2];
    if qa != 0.0 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let r = disc.sqrt();
            events.push((-qb - r) / (2.0 * qa));
            events.push((-qb + r) / (2.0 * qa));
        }
    } else if qb != 0.0 {
        events.push(-qc / qb);
    }
    events.retain(|t| *t > 0.0 && *t < 1.0);
    events.sort_by(f64::total_cmp);
    events.dedup();
    let mut samples = vec![0.0];
    let mut prev = 0.0;
    for &t in events.iter().chain(std::iter::once(&1.0)) {
        samples.push(0.5 * (prev + t));
        prev = t;
    }
    samples.push(1.0);

    // Union-find over (sample, section corner) nodes.
    let n = samples.len() * 4;
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    fn union(p: &mut [usize], a: usize, b: usize) {
        let (ra, rb) = (find(p, a), find(p, b));
        p[ra.max(rb)] = ra.min(rb);
    }
    let mut prev_in = [false; 4];
    for (s, &t) in samples.iter().enumerate() {
        let gt: [f64; 4] = std::array::from_fn(|q| a[q] + t * b[q]);
        let ins: [bool; 4] = gt.map(|v| v > 0.0);
        // Section edges (square 0-1-3-2).
        for (p, q) in [(0, 1), (1, 3), (3, 2), (2, 0)] {
            if ins[p] == ins[q] {
                union(&mut parent, 4 * s + p, 4 * s + q);
            }
        }
        // Section saddle.
        if ins[0] == ins[3] && ins[1] == ins[2] && ins[0] != ins[1] {
            let s03 = gt[0] * gt[3] - gt[1] * gt[2];
            let join_03 = if ins[0] { s03 > 0.0 } else { s03 >= 0.0 };
            if join_03 {
                union(&mut parent, 4 * s, 4 * s + 3);
            } else {
                union(&mut parent, 4 * s + 1, 4 * s + 2);
            }
        }
        // Vertical edges that keep their side.
        if s > 0 {
            for q in 0..4 {
                if ins[q] == prev_in[q] {
                    union(&mut parent, 4 * (s - 1) + q, 4 * s + q);
                }
            }
        }
        prev_in = ins;
    }
    let last = samples.len() - 1;
    let node = |c: u8| {
        let q = usize::from(c & 3);
        if c & 4 == 0 {
            q
        } else {
            4 * last + q
        }
    };
    for c1 in 0..8u8 {
        for c2 in c1 + 1..8 {
            if find(&mut parent, node(c1)) == find(&mut parent, node(c2)) {
                regions.union(c1, c2);
            }
        }
    }
}

/// Bitmask of the faces (bit = index in [`FACES`]) that contain Bourke edge `e`.
fn edge_faces(e: usize) -> u8 {
    let mut mask = 0;
    for (fi, face) in FACES.iter().enumerate() {
        for k in 0..4 {
            if edge_of(face[k], face[(k + 1) % 4]) == e {
                mask |= 1 << fi;
            }
        }
    }
    mask
}

/// Whether edges `a` and `b` (Bourke numbers) lie on a common face of the cell. A triangle edge
/// between two such vertices lies in the face plane; unless it is a contour segment, the cell
/// across the face could draw the same edge, so it is never drawn.
fn share_face(a: usize, b: usize) -> bool {
    edge_faces(a) & edge_faces(b) != 0
}

/// A vertex of a cell's triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Vert {
    /// The vertex of a crossed edge (Bourke number).
    Edge(usize),
    /// Added inside the cell: at the mean of a contour's vertices.
    Centre(usize),
    /// Added inside the cell: near the midpoint of the rung between two edge vertices.
    Mid(usize, usize),
}

/// A disk's triangles: a fan from the first contour vertex that shares no face with a
/// non-neighbouring vertex of the contour, or, if there is none, a fan around a vertex added
/// at the contour's centre (`Centre(index of the contour's first edge)`).
fn disk(c: &[usize]) -> Vec<[Vert; 3]> {
    let n = c.len();
    let apex = (0..n).find(|&a| {
        (0..n).all(|w| {
            let d = (w + n - a) % n;
            d <= 1 || d == n - 1 || !share_face(c[a], c[w])
        })
    });
    match apex {
        Some(a) => (1..n - 1)
            .map(|k| [Vert::Edge(c[a]), Vert::Edge(c[(a + k) % n]), Vert::Edge(c[(a + k + 1) % n])])
            .collect(),
        None => (0..n)
            .map(|w| [Vert::Centre(c[0]), Vert::Edge(c[w]), Vert::Edge(c[(w + 1) % n])])
            .collect(),
    }
}

/// Progress of a walk's moves on one contour: none yet, all at the other contour's current
/// vertex, all at one earlier vertex, or spread over several (the only valid end state: a walk
/// that makes all its moves on one contour in a row returns to its starting rung early).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Spread {
    None,
    Here,
    Before,
    Several,
}

impl Spread {
    /// After a move on this contour.
    fn moved(self) -> Spread {
        match self {
            Spread::None | Spread::Here => Spread::Here,
            Spread::Before | Spread::Several => Spread::Several,
        }
    }
    /// After a move on the other contour.
    fn waited(self) -> Spread {
        match self {
            Spread::Here => Spread::Before,
            s => s,
        }
    }
    fn index(self) -> usize {
        self as usize
    }
}

/// Triangulates a tunnel between contours `p` and `q` (both oriented as surface boundaries) as
/// a strip: walk `p` forwards and `q` backwards; each step adds a triangle with the next
/// vertex of one of them, and the *rung* joining the current vertices of both moves on. Of all
/// closed walks that use every rung once, the one with the fewest rungs joining two vertices on
/// a common face (see [`share_face`]), then the smallest sum of squared rung lengths (index
/// space, `pos`), is taken; ties go to the walk found first (start at `p[0]` and each vertex of
/// reversed `q` in turn; prefer advancing `p`). A rung on a common face is split by a vertex
/// `Mid` added near its midpoint, and each triangle touching it becomes a fan around that
/// vertex. Emits at least `|p| + |q|` triangles.
fn tube(p: &[usize], q: &[usize], pos: &dyn Fn(usize) -> DVec3) -> Vec<[Vert; 3]> {
    const S: [Spread; 4] = [Spread::None, Spread::Here, Spread::Before, Spread::Several];
    let qr: Vec<usize> = q.iter().rev().copied().collect();
    let (n, m) = (p.len(), qr.len());
    let mut best: Option<(f64, Vec<[usize; 3]>)> = None;
    for j0 in 0..m {
        let pv = |i: usize| p[i % n];
        let qv = |j: usize| qr[(j0 + j) % m];
        // Every rung costs its squared length, plus 1000 (more than any sum of squared lengths
        // in a unit cell) if it has to be split.
        let len = |i: usize, j: usize| {
            let split = if share_face(pv(i), qv(j)) { 1000.0 } else { 0.0 };
            split + pos(pv(i)).distance_squared(pos(qv(j)))
        };
        // cost[i][j][sp][sq]: cheapest walk from rung (0, 0) to rung (i, j) with the given
        // spreads of its p and q moves; back[..] = (came by a p move, previous sp, previous sq).
        let idx = |i: usize, j: usize, a: usize, b: usize| ((i * (m + 1) + j) * 4 + a) * 4 + b;
        let size = (n + 1) * (m + 1) * 16;
        let mut cost = vec![f64::INFINITY; size];
        let mut back = vec![(false, 0usize, 0usize); size];
        cost[idx(0, 0, 0, 0)] = len(0, 0);
        for i in 0..=n {
            for j in 0..=m {
                for (a, sa) in S.iter().enumerate() {
                    for (b, sb) in S.iter().enumerate() {
                        let k = idx(i, j, a, b);
                        let c = cost[k];
                        if !c.is_finite() {
                            continue;
                        }
                        // Advance p, then q.
                        if i < n {
                            let (na, nb) = (sa.moved().index(), sb.waited().index());
                            let h = if (i + 1, j) == (n, m) { 0.0 } else { len(i + 1, j) };
                            let t = idx(i + 1, j, na, nb);
                            if c + h < cost[t] {
                                cost[t] = c + h;
                                back[t] = (true, a, b);
                            }
                        }
                        if j < m {
                            let (na, nb) = (sa.waited().index(), sb.moved().index());
                            let h = if (i, j + 1) == (n, m) { 0.0 } else { len(i, j + 1) };
                            let t = idx(i, j + 1, na, nb);
                            if c + h < cost[t] {
                                cost[t] = c + h;
                                back[t] = (false, a, b);
                            }
                        }
                    }
                }
            }
        }
        let end = idx(n, m, Spread::Several.index(), Spread::Several.index());
        let total = cost[end];
        if !total.is_finite() || best.as_ref().is_some_and(|(b, _)| *b <= total) {
            continue;
        }
        let mut tris = Vec::with_capacity(n + m);
        let (mut i, mut j, mut a, mut b) = (n, m, Spread::Several.index(), Spread::Several.index());
        while (i, j) != (0, 0) {
            let (by_p, pa, pb) = back[idx(i, j, a, b)];
            if by_p {
                tris.push([pv(i - 1), pv(i), qv(j)]);
                i -= 1;
            } else {
                tris.push([pv(i), qv(j), qv(j - 1)]);
                j -= 1;
            }
            (a, b) = (pa, pb);
        }
        tris.reverse();
        best = Some((total, tris));
    }
    let Some((_, tris)) = best else { unreachable!("a strip between two contours always exists") };
    // Split the rungs on a common face: each strip triangle has one contour edge (its first
    // two vertices for a p step, its last two for a q step) and two rungs.
    let mut out = Vec::with_capacity(tris.len() + 4);
    for t in tris {
        // Vertices in order with each split rung's midpoint inserted after its first end.
        let mut poly: Vec<Vert> = Vec::with_capacity(5);
        let mut last_mid = None;
        for k in 0..3 {
            let (x, y) = (t[k], t[(k + 1) % 3]);
            poly.push(Vert::Edge(x));
            let is_rung = p.contains(&x) != p.contains(&y);
            if is_rung && share_face(x, y) {
                last_mid = Some(poly.len());
                poly.push(Vert::Mid(x.min(y), x.max(y)));
            }
        }
        match last_mid {
            None => out.push([poly[0], poly[1], poly[2]]),
            Some(c) => {
                let n = poly.len();
                for k in 1..n - 1 {
                    out.push([poly[c], poly[(c + k) % n], poly[(c + k + 1) % n]]);
                }
            }
        }
    }
    out
}

/// The reference: the whole grid as one slab.
pub(crate) fn extract(f: &Field) -> Result<Mesh, MeshError> {
    let layers = f.dims[2] - 1;
    slabs::run(layers, layers, false, |cells| extract_slab(f, cells))
}

/// The edge vertices of the edges starting in point layers `cells` (and in the last point
/// layer if `cells` ends at the grid's top), the added vertices and the triangles of cell
/// layers `cells`, numbered locally (see `slabs`).
pub(crate) fn extract_slab(f: &Field, cells: Range<usize>) -> Result<Part, MeshError> {
    let [nx, ny, _] = f.dims;
    let mut verts = Vertices::default();
    let mut indices = Vec::new();
    // Added vertices, numbered after all edge vertices; triangles refer to added vertex c as
    // `u32::MAX - c` until the join. Positioned here, where the field is at hand (a window's
    // join may run where it is not, see `window`).
    let mut centres = Vertices::default();
    let mut edges = EdgeLayers::new(f, FAMILIES);
    let sign = match f.inside {
        Inside::Below => -1.0,
        Inside::Above => 1.0,
    };
    edges.build(cells.start, &mut verts)?;
    for k in cells.clone() {
        edges.enter_cell_layer(k, &cells, &mut verts)?;
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                // With a missing corner the mask is not a case; such a cell is skipped either
                // way: no surface (`field::interpolant::cell_missing`).
                let mask = edges.corner_mask(i, j, k);
                if mask == 0 || mask == 0xff || edges.cell_missing(i, j, k) {
                    continue;
                }
                let v = f.corners(i, j, k);
                let g = v.map(|x| sign * (x - f.iso));
                let cell = DVec3::new(i as f64, j as f64, k as f64);
                // Index-space crossing point of Bourke edge e, and its inside -> outside
                // direction.
                let point = |e: usize| {
                    let (c, axis) = MC_EDGES[e];
                    let end = c | (1 << axis);
                    let s = f.crossing(v[c as usize], v[end as usize]);
                    let o = offset(c);
                    let mut u = cell + DVec3::new(o[0] as f64, o[1] as f64, o[2] as f64);
                    u[usize::from(axis)] += s;
                    let mut d = DVec3::ZERO;
                    d[usize::from(axis)] = if g[c as usize] > 0.0 { 1.0 } else { -1.0 };
                    (u, d)
                };
                let vid = |e: usize| {
                    let (corner, axis) = MC_EDGES[e];
                    let o = offset(corner);
                    edges.id(i + o[0], j + o[1], k + o[2], usize::from(axis))
                };
                let pos = |e: usize| point(e).0;
                let mut added: Vec<(Vert, u32)> = Vec::new();
                for piece in cell_pieces(&g) {
                    let tris = match piece.as_slice() {
                        [c] => disk(c),
                        [p, q] => tube(p, q, &pos),
                        _ => unreachable!("pieces have one or two contours"),
                    };
                    for t in tris {
                        for v in t {
                            let id = match v {
                                Vert::Edge(e) => vid(e),
                                _ => match added.iter().find(|(w, _)| *w == v) {
                                    Some(&(_, id)) => id,
                                    None => {
                                        let (u, dir) = match v {
                                            Vert::Centre(e0) => {
                                                let c = piece
                                                    .iter()
                                                    .find(|c| c[0] == e0)
                                                    .map_or(&piece[0], |c| c);
                                                let (su, sd) = c.iter().fold(
                                                    (DVec3::ZERO, DVec3::ZERO),
                                                    |(s, d), &e| {
                                                        let (u, de) = point(e);
                                                        (s + u, d + de)
                                                    },
                                                );
                                                (su / c.len() as f64, sd)
                                            }
                                            Vert::Mid(a, b) => {
                                                let (ua, da) = point(a);
                                                let (ub, db) = point(b);
                                                let mid = 0.5 * (ua + ub);
                                                (
                                                    mid + 0.25 * (cell + DVec3::splat(0.5) - mid),
                                                    da + db,
                                                )
                                            }
                                            Vert::Edge(_) => unreachable!(),
                                        };
                                        let id = u32::MAX - centres.positions.len() as u32;
                                        centres.push(f, u, dir)?;
                                        added.push((v, id));
                                        id
                                    }
                                },
                            };
                            indices.push(id);
                        }
                    }
                }
            }
        }
    }
    Ok(Part { verts, indices, quads: Vec::new(), added: centres })
}
