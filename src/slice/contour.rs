//! Contours of the field on a plane: marching squares on the cells of a quadtree over the
//! plane's grid cells, stitched into ordered loops and polylines.
//!
//! # Cells and values
//!
//! The quadtree's roots are the plane's grid cells; `max_depth` levels below them its vertices
//! sit on a lattice of `2^max_depth` points per cell side (integer lattice coordinates, so two
//! cells agree exactly on what a shared vertex or edge is). Vertex values come from one of two
//! functions:
//!
//! - **bilinear** (no refinement, or a source that cannot be evaluated off the grid): the
//!   bilinear interpolant of the plane's values. Along an axis-aligned edge it is linear, so a
//!   crossing is found exactly by linear interpolation, and every contour point lies on the
//!   bilinear zero set.
//! - **source** (`max_depth > 0` with a source that can be evaluated anywhere: sdf, corners,
//!   expr, mesh): the source itself, evaluated at world points; crossings are found by bracketed root finding on the source
//!   along the edge, so refined contours follow the source beyond the grid's resolution.
//! - **another interpolant** (`PlaneGrid::interp`): a cubic one is the source itself (the caller
//!   passes it, `slice::interpolant_source`), used at every depth, so crossings are its own
//!   roots; nearest's contour is its voxels' edges: each crossing halfway along the edge
//!   (where the voxels meet), each segment turning at its cell's centre, no refinement.
//!
//! # Refinement
//!
//! A cell above `max_depth` is split when its corners (and, with a source, its centre) do not
//! all agree on the inside test, or when, with a source, the centre is within `L` times the
//! half-diagonal of the isovalue (`L` a Lipschitz bound of the source: 1 for the sphere, box and
//! torus distances, 2 sqrt(3) for the gyroid; for expr and corners sources twice the steepest
//! slope between plane grid points, a heuristic that can miss features far below the grid's
//! resolution). A bilinear cell whose corners agree holds no contour, so it is never split.
//!
//! Neighbours of different sizes meet at T-junctions:
//!
//! ```text
//!   +-------+---+---+      the big cell's right edge carries the small cells' vertex m.
//!   |       |   |   |      If the inside test changes more often along a-m-b than between
//!   |   L   m---+---+      a and b alone, L is split (repeated until no cell needs it), so
//!   |       |   |   |      every edge crossing lies on one lattice sub-edge that both sides
//!   +-------+---+---+      see and compute identically: the contour has no cracks.
//!   a       b
//! ```
//!
//! # Stitching
//!
//! Each leaf contributes oriented segments (see [`super::squares`]) between crossing keys (the
//! lattice sub-edge a crossing lies on). A key is the end of at most one segment and the start
//! of at most one, so chains are followed exactly: chains that start at a key no segment ends at
//! are open polylines from box side to box side, the rest closed loops. Loops and polylines keep
//! the inside on their left in the picture (u right, v up): loops around inside regions run
//! counterclockwise, loops around holes clockwise. A closed contour does not repeat its first
//! point; consecutive equal points (contours through a grid point whose value equals the
//! isovalue) are merged and contours that shrink to one point are dropped.

use std::collections::{HashMap, HashSet};

use glam::{DVec2, DVec3};

use super::plane::PlaneGrid;
use super::squares;
use super::SliceError;
use crate::field::interpolant::Interpolant;
use crate::field::SourceKind;
use crate::scene::{Ambiguity, Inside};

/// What to extract.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContourOptions {
    pub isovalue: f64,
    pub inside: Inside,
    pub ambiguity: Ambiguity,
    /// Quadtree levels below the grid's cells (0: the grid's cells only).
    pub max_depth: u32,
}

/// A field's source as a function of world position, for `ambiguity = "sample"` and refinement
/// (the source builds it: [`crate::field::FieldSource::point`]).
pub use crate::field::PointField as SourceField;

/// One contour: an open polyline from box side to box side, or a closed loop.
#[derive(Clone, Debug, PartialEq)]
pub struct Contour {
    pub closed: bool,
    /// Plane index coordinates (see [`super::plane`]), in order, inside on the left.
    pub points: Vec<DVec2>,
}

impl Contour {
    /// Twice the signed area of a closed contour in plane index space (positive when it runs
    /// counterclockwise, i.e. around an inside region).
    pub fn signed_area2(&self) -> f64 {
        let n = self.points.len();
        (0..n)
            .map(|i| {
                let (a, b) = (self.points[i], self.points[(i + 1) % n]);
                a.x * b.y - b.x * a.y
            })
            .sum()
    }
}

/// Counts of what the extraction did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ContourStats {
    /// Leaf cells marched.
    pub cells: usize,
    /// Leaves in case 5 or 10, and how many of those were joined through the centre.
    pub ambiguous: usize,
    pub joined: usize,
    /// Whether vertex values came from the source (refinement on the source).
    pub on_source: bool,
    /// Source evaluations.
    pub evaluations: usize,
}

/// The contours of one plane.
#[derive(Clone, Debug, PartialEq)]
pub struct ContourSet {
    pub contours: Vec<Contour>,
    pub stats: ContourStats,
}

impl ContourSet {
    /// `(closed, open)` contour counts.
    pub fn counts(&self) -> (usize, usize) {
        let closed = self.contours.iter().filter(|c| c.closed).count();
        (closed, self.contours.len() - closed)
    }
}

/// A lattice point: `2^max_depth` units per grid cell side.
type Vertex = (i64, i64);
/// A crossing: the lattice sub-edge it lies on, endpoints in increasing order.
type Key = (Vertex, Vertex);

/// A quadtree leaf: lower-left vertex and side, in lattice units.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Leaf {
    y: i64,
    x: i64,
    size: i64,
}

impl Leaf {
    /// Corners counterclockwise from the lower left.
    fn corners(&self) -> [Vertex; 4] {
        let (x, y, s) = (self.x, self.y, self.size);
        [(x, y), (x + s, y), (x + s, y + s), (x, y + s)]
    }

    fn children(&self) -> [Leaf; 4] {
        let h = self.size / 2;
        [(0, 0), (h, 0), (0, h), (h, h)].map(|(dx, dy)| Leaf {
            x: self.x + dx,
            y: self.y + dy,
            size: h,
        })
    }
}

struct Lattice<'p, 's> {
    plane: &'p PlaneGrid,
    /// Lattice units per grid cell side.
    scale: i64,
    /// Vertex values from this source (else the bilinear interpolant).
    source: Option<&'s SourceField<'s>>,
    /// For `ambiguity = "sample"` without refinement.
    sample: Option<&'s SourceField<'s>>,
    opts: ContourOptions,
    /// Values at the corners of every leaf (and of every cell that was split).
    corners: HashMap<Vertex, f64>,
    /// Source values at cell centres, keyed by doubled lattice coordinates.
    centres: HashMap<Vertex, f64>,
    crossings: HashMap<Key, DVec2>,
    evaluations: usize,
}

impl<'p, 's> Lattice<'p, 's> {
    fn index_point(&self, v: Vertex) -> DVec2 {
        DVec2::new(v.0 as f64, v.1 as f64) / self.scale as f64
    }

    fn inside(&self, value: f64) -> bool {
        self.opts.inside.contains(value, self.opts.isovalue)
    }

    fn eval_source(&mut self, source: &SourceField, q: DVec2) -> f64 {
        self.evaluations += 1;
        (source.eval)(self.plane.index_to_world(q))
    }

    fn corner(&mut self, v: Vertex) -> f64 {
        if let Some(&x) = self.corners.get(&v) {
            return x;
        }
        let q = self.index_point(v);
        let x = match self.source {
            Some(s) => self.eval_source(s, q),
            None => self.plane.bilinear(q),
        };
        self.corners.insert(v, x);
        x
    }

    /// The source at the centre of `leaf` (cached).
    fn centre(&mut self, leaf: &Leaf, source: &SourceField) -> f64 {
        let key = (2 * leaf.x + leaf.size, 2 * leaf.y + leaf.size);
        if let Some(&x) = self.centres.get(&key) {
            return x;
        }
        let q = DVec2::new(key.0 as f64, key.1 as f64) / (2 * self.scale) as f64;
        let x = self.eval_source(source, q);
        self.centres.insert(key, x);
        x
    }

    /// Whether the first refinement pass splits `leaf` (see the module docs).
    fn wants_split(&mut self, leaf: &Leaf, lipschitz: f64) -> bool {
        let values = leaf.corners().map(|v| self.corner(v));
        let first = self.inside(values[0]);
        if values.iter().any(|&x| self.inside(x) != first) {
            return true;
        }
        let Some(source) = self.source else {
            return false;
        };
        let c = self.centre(leaf, source);
        if self.inside(c) != first {
            return true;
        }
        let cell = self.plane.spacing() * (leaf.size as f64 / self.scale as f64);
        (c - self.opts.isovalue).abs() <= lipschitz * 0.5 * cell.length()
    }

    /// Existing vertices strictly between `a` and `b` (an axis-aligned leaf edge), in order.
    fn between(&self, a: Vertex, b: Vertex, out: &mut Vec<Vertex>) {
        if (b.0 - a.0).abs() + (b.1 - a.1).abs() <= 1 {
            return;
        }
        let m = ((a.0 + b.0) / 2, (a.1 + b.1) / 2);
        if self.corners.contains_key(&m) {
            self.between(a, m, out);
            out.push(m);
            self.between(m, b, out);
        }
    }

    /// The vertices along the edge from `a` to `b`, ends included.
    fn edge(&self, a: Vertex, b: Vertex) -> Vec<Vertex> {
        let mut out = vec![a];
        self.between(a, b, &mut out);
        out.push(b);
        out
    }

    /// Whether some edge of `leaf` changes inside-ness more often through the vertices on it
    /// than between its ends (a T-junction that would crack the contour).
    fn inconsistent(&self, leaf: &Leaf) -> bool {
        let c = leaf.corners();
        (0..4).any(|k| {
            let points = self.edge(c[k], c[(k + 1) % 4]);
            if points.len() == 2 {
                return false;
            }
            let ins: Vec<bool> = points.iter().map(|v| self.inside(self.corners[v])).collect();
            let changes = ins.windows(2).filter(|w| w[0] != w[1]).count();
            changes > usize::from(ins[0] != ins[ins.len() - 1])
        })
    }

    /// The key of the crossing on the edge from `a` to `b` (whose ends differ in inside-ness).
    fn crossing_key(&self, a: Vertex, b: Vertex) -> Key {
        let points = self.edge(a, b);
        let k = points
            .windows(2)
            .position(|w| self.inside(self.corners[&w[0]]) != self.inside(self.corners[&w[1]]))
            .unwrap_or(0);
        let (p, q) = (points[k], points[k + 1]);
        if p <= q {
            (p, q)
        } else {
            (q, p)
        }
    }

    /// The crossing on sub-edge `key`, plane index coordinates (cached, so both cells sharing
    /// the sub-edge get the same point).
    fn crossing(&mut self, key: Key) -> DVec2 {
        if let Some(&q) = self.crossings.get(&key) {
            return q;
        }
        let (a, b) = (self.index_point(key.0), self.index_point(key.1));
        let (fa, fb) = (self.corners[&key.0], self.corners[&key.1]);
        let iso = self.opts.isovalue;
        let t = match self.source {
            // Nearest: the face between two voxels lies halfway between their points.
            None if self.plane.interp == Interpolant::Nearest => 0.5,
            None => ((iso - fa) / (fb - fa)).clamp(0.0, 1.0),
            Some(source) => {
                let (plane, inside) = (self.plane, self.opts.inside);
                let mut evaluations = 0;
                let t = super::roots::bracketed(
                    |t| {
                        evaluations += 1;
                        (source.eval)(plane.index_to_world(a + (b - a) * t)) - iso
                    },
                    fa - iso,
                    fb - iso,
                    |g| inside.contains(g, 0.0),
                );
                self.evaluations += evaluations;
                t
            }
        };
        let q = a + (b - a) * t;
        self.crossings.insert(key, q);
        q
    }
}

/// Steepest slope between neighbouring plane grid points, per world unit.
fn steepest_slope(plane: &PlaneGrid) -> f64 {
    let h = plane.spacing();
    let [nu, nv] = plane.dims;
    let mut m: f64 = 0.0;
    for j in 0..nv {
        for i in 0..nu {
            if i + 1 < nu {
                m = m.max((plane.at(i + 1, j) - plane.at(i, j)).abs() / h.x);
            }
            if j + 1 < nv {
                m = m.max((plane.at(i, j + 1) - plane.at(i, j)).abs() / h.y);
            }
        }
    }
    m
}

/// Extracts the contours of `plane` (see the module docs). `source` is needed for
/// `ambiguity = "sample"` and for refinement on the source; without it `max_depth > 0` refines
/// the bilinear interpolant.
pub fn extract(
    plane: &PlaneGrid,
    source: Option<&SourceField>,
    opts: &ContourOptions,
) -> Result<ContourSet, SliceError> {
    if opts.ambiguity == Ambiguity::Sample && source.is_none() {
        return Err(SliceError::Input(format!(
            "slice.ambiguity = \"sample\" needs a field source that can be evaluated ({})",
            SourceKind::names_where(|k| k.supports().point)
        )));
    }
    if opts.max_depth > crate::scene::MAX_SLICE_DEPTH as u32 {
        return Err(SliceError::Input(format!(
            "slice.max_depth = {}: at most {}",
            opts.max_depth,
            crate::scene::MAX_SLICE_DEPTH
        )));
    }
    // Nearest's contours are its voxels' edges, known at the plane's own cells: no refinement.
    let nearest = plane.interp == Interpolant::Nearest;
    let depth = if nearest { 0 } else { opts.max_depth };
    let scale = 1i64 << depth;
    // A cubic interpolant's plane is the interpolant itself (the caller's source,
    // `slice::scene_contours`): its corners and crossings, refined or not.
    let cubic = plane.interp.stencil().width() > 2;
    let on_source = (depth > 0 || cubic) && source.is_some();
    let mut lat = Lattice {
        plane,
        scale,
        source: if on_source { source } else { None },
        sample: source,
        opts: *opts,
        corners: HashMap::new(),
        centres: HashMap::new(),
        crossings: HashMap::new(),
        evaluations: 0,
    };
    let lipschitz = source.and_then(|s| s.lipschitz).unwrap_or_else(|| 2.0 * steepest_slope(plane));

    // Refine: split where the contour may pass, then until no T-junction cracks it.
    let [cu, cv] = plane.cells();
    let mut stack: Vec<Leaf> = (0..cv as i64)
        .rev()
        .flat_map(|j| {
            (0..cu as i64).rev().map(move |i| Leaf { x: i * scale, y: j * scale, size: scale })
        })
        .collect();
    let mut leaves = Vec::with_capacity(stack.len());
    while let Some(leaf) = stack.pop() {
        for v in leaf.corners() {
            lat.corner(v);
        }
        if leaf.size > 1 && lat.wants_split(&leaf, lipschitz) {
            stack.extend(leaf.children().iter().rev());
        } else {
            leaves.push(leaf);
        }
    }
    if depth > 0 {
        loop {
            let mut next = Vec::with_capacity(leaves.len());
            let mut split = false;
            for leaf in &leaves {
                if leaf.size > 1 && lat.inconsistent(leaf) {
                    for child in leaf.children() {
                        for v in child.corners() {
                            lat.corner(v);
                        }
                        next.push(child);
                    }
                    split = true;
                } else {
                    next.push(*leaf);
                }
            }
            leaves = next;
            if !split {
                break;
            }
        }
    }
    leaves.sort();

    // March every leaf.
    let mut stats = ContourStats { cells: leaves.len(), on_source, ..Default::default() };
    let mut segments: Vec<(Key, Key)> = Vec::new();
    // Nearest: the point each segment passes through between its two crossings.
    let mut turns: HashMap<(Key, Key), DVec2> = HashMap::new();
    for leaf in &leaves {
        // A missing cell holds no contour (`field::interpolant::cell_missing`).
        if plane.cell_missing((leaf.x / scale) as usize, (leaf.y / scale) as usize) {
            continue;
        }
        let c = leaf.corners();
        let values = c.map(|v| lat.corners[&v]);
        let case = squares::case_index(values.map(|x| lat.inside(x)));
        if case == 0 || case == 15 {
            continue;
        }
        let mut centre_inside = false;
        if squares::is_ambiguous(case) {
            stats.ambiguous += 1;
            let sampler = lat.sample;
            let mut sampled = None;
            if opts.ambiguity == Ambiguity::Sample {
                if let Some(s) = sampler {
                    sampled = Some(lat.centre(leaf, s));
                }
            }
            centre_inside = squares::centre_inside(
                opts.ambiguity,
                values,
                || sampled,
                opts.isovalue,
                opts.inside,
            );
            stats.joined += usize::from(centre_inside);
        }
        for &[from, to] in squares::segments(case, centre_inside) {
            let key = |e: u8| lat.crossing_key(c[e as usize], c[(e as usize + 1) % 4]);
            let (a, b) = (key(from), key(to));
            lat.crossing(a);
            lat.crossing(b);
            segments.push((a, b));
            if nearest {
                // The voxels' edges turn at the cell's centre, where the four voxels meet.
                let centre = DVec2::new(leaf.x as f64 + 0.5, leaf.y as f64 + 0.5);
                turns.insert((a, b), centre);
            }
        }
    }

    let mut contours = Vec::new();
    for (closed, keys) in stitch(&segments) {
        let mut points: Vec<DVec2> = Vec::with_capacity(keys.len());
        let n = keys.len();
        for (i, &k) in keys.iter().enumerate() {
            let p = lat.crossings[&k];
            if points.last() != Some(&p) {
                points.push(p);
            }
            let next = if i + 1 < n { Some(keys[i + 1]) } else { closed.then(|| keys[0]) };
            if let Some(turn) = next.and_then(|m| turns.get(&(k, m))) {
                points.push(*turn);
            }
        }
        if closed && points.len() > 1 && points.first() == points.last() {
            points.pop();
        }
        if points.len() > 1 {
            contours.push(Contour { closed, points });
        }
    }
    stats.evaluations = lat.evaluations;
    Ok(ContourSet { contours, stats })
}

/// Follows segments `(from, to)` into chains of keys: `(closed, keys)`, open chains first (in
/// the order of their first segment), then loops (a loop does not repeat its first key).
fn stitch(segments: &[(Key, Key)]) -> Vec<(bool, Vec<Key>)> {
    let mut by_from: HashMap<Key, usize> = HashMap::with_capacity(segments.len());
    for (i, s) in segments.iter().enumerate() {
        by_from.entry(s.0).or_insert(i);
    }
    let ends: HashSet<Key> = segments.iter().map(|s| s.1).collect();
    let mut used = vec![false; segments.len()];
    let mut out = Vec::new();
    let follow = |start: usize, used: &mut Vec<bool>| {
        let mut keys = vec![segments[start].0];
        let mut i = start;
        loop {
            used[i] = true;
            keys.push(segments[i].1);
            match by_from.get(&segments[i].1) {
                Some(&j) if j == start => {
                    keys.pop();
                    return (true, keys);
                }
                Some(&j) if !used[j] => i = j,
                _ => return (false, keys),
            }
        }
    };
    for i in 0..segments.len() {
        if !used[i] && !ends.contains(&segments[i].0) {
            out.push(follow(i, &mut used));
        }
    }
    for i in 0..segments.len() {
        if !used[i] {
            out.push(follow(i, &mut used));
        }
    }
    out
}

/// The world points of a contour on `plane`.
pub fn world_points(plane: &PlaneGrid, contour: &Contour) -> Vec<DVec3> {
    contour.points.iter().map(|&q| plane.index_to_world(q)).collect()
}
