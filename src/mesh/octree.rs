//! Adaptive `dual-contouring-qef` (`render.mesh_error = ε`): Ju, Losasso, Schaefer & Warren's
//! octree simplification and contouring (SIGGRAPH 2002, sections 3.2 and 4), on the CPU.
//!
//! ```text
//!   grid cells (leaves)      collapse where safe and flat        contour the leaves:
//!   ┌─┬─┬─┬─┐                ┌───┬─┬─┐                           one quad per crossed minimal
//!   ├─┼─┼─┼─┤                │ ● ├─┼─┤                           edge, from the 4 leaves
//!   ├─┼─┼─┼─┤      ──→       ├───┼─┼─┤                           around it (3 when two are
//!   └─┴─┴─┴─┘                └───┴─┴─┘                           one leaf: a triangle)
//! ```
//!
//! 1. **Octree** over the grid's cells, root side the next power of two of the largest cell
//!    count. A leaf at the finest level is an active cell of the grid with
//!    `dual-contouring-qef`'s QEF (`dcqef.rs`) and vertex. Nodes are built bottom-up; children
//!    outside the grid or without a crossed edge are absent.
//! 2. **Collapse**: a node whose children are all leaves (or absent), which lies inside the
//!    grid without touching its faces, becomes one leaf when it is *topology-safe* (Ju et al. 4.2, after Gerstner &
//!    Pajarola): its 8 corners' signs form one piece (inside corners connected along the
//!    node's edges, outside corners too), so does every child leaf's, and the sign at each
//!    edge's midpoint, each face's centre and the node's centre equals the sign at one of that
//!    edge's, face's or node's corners; and when the sum of its children's QEFs, solved for a
//!    vertex kept in the node (`qef.rs`), leaves an error `E` with `E · max(spacing)² ≤ ε²`.
//!    `E` sums squared index-space distances to every tangent plane below the node, and a
//!    world distance is at most the index one times the largest spacing, so the vertex lies
//!    within ε (world units) of each of those planes.
//! 3. **Contour**: Ju et al.'s recursive `cell → face → edge` procedure visits every minimal
//!    edge (an edge of a leaf not split by a smaller one) shared by 4 leaves; where its end
//!    points' signs differ, the 4 leaves' vertices make a quad (a triangle where two of them
//!    are the same leaf), counter-clockwise seen from outside. Leaves on a face of different
//!    sizes meet without cracks because each minimal edge is taken from the smallest leaf.
//!
//! Vertices are numbered in depth-first order of the leaves (children in the order of their
//! corner bits, x + 2y + 4z); triangles in the procedure's order. The surface is open where it
//! reaches the grid's box (as `surface-nets`): the octree has no padding cells. Not threaded:
//! the threaded CPU path runs this as it is. Quads are not returned.
//!
//! Memory: the octree's nodes (a leaf holds its QEF), about 7 times the mesh (2.6 GB for the
//! 355 MB mesh of a 256^3 noise grid); checked against the mesh cap as the tree grows
//! ([`MeshBudget::check_working`]), since the mesh itself is counted only once it is done.

use glam::DVec3;

use super::dcqef::DcQef;
use super::edges::Vertices;
use super::qef::Qef;
use super::{to_u32, Mesh, MeshBudget, MeshError};

/// Nodes built between two looks at the memory cap.
const NODES_PER_CHECK: usize = 4096;

/// An octree node; `min` and `size` in cells.
enum Node {
    Leaf {
        min: [usize; 3],
        size: usize,
        qef: Qef,
        /// Index-space vertex.
        vertex: DVec3,
        /// Its sign configuration is one piece (collapsible).
        manifold: bool,
        /// Vertex id, given after the collapse.
        id: u32,
    },
    /// Children by corner bits `x + 2y + 4z`.
    Internal { children: [Option<usize>; 8] },
}

/// Children indexed by corner bits x + 2y + 4z (the crate's corner order).
fn bits(c: usize) -> [usize; 3] {
    [c & 1, (c >> 1) & 1, (c >> 2) & 1]
}

struct Octree<'q, 'f, 'g, 's, 'b> {
    q: &'q DcQef<'f, 'g, 's>,
    nodes: Vec<Node>,
    budget: &'b MeshBudget,
    /// The cap's refusal, once the nodes passed it: the build stops.
    over: Option<MeshError>,
    /// Cells per axis.
    nc: [usize; 3],
    /// ε² / max(spacing)², in index units squared.
    limit: f64,
}

impl Octree<'_, '_, '_, '_, '_> {
    /// Pushes `node`; every [`NODES_PER_CHECK`] nodes, checks what the nodes take (the
    /// vector's capacity) against the cap.
    fn push(&mut self, node: Node) -> usize {
        self.nodes.push(node);
        if self.nodes.len() % NODES_PER_CHECK == 0 {
            let bytes = (self.nodes.capacity() * std::mem::size_of::<Node>()) as u64;
            let what = "its octree's nodes, each leaf with its QEF";
            if let Err(e) = self.budget.check_working("dual-contouring-qef", what, bytes) {
                self.over = Some(e);
            }
        }
        self.nodes.len() - 1
    }

    fn inside(&self, p: [usize; 3]) -> bool {
        self.q.hermite.f.is_inside(p[0], p[1], p[2])
    }

    /// Signs of the 8 corners of the cube at `min` with side `size`.
    fn signs(&self, min: [usize; 3], size: usize) -> [bool; 8] {
        std::array::from_fn(|c| {
            let o = bits(c);
            self.inside([min[0] + o[0] * size, min[1] + o[1] * size, min[2] + o[2] * size])
        })
    }

    fn build(&mut self, min: [usize; 3], size: usize) -> Option<usize> {
        if (0..3).any(|a| min[a] >= self.nc[a]) || self.over.is_some() {
            return None;
        }
        if size == 1 {
            let s = self.signs(min, 1);
            if s.iter().all(|&x| x == s[0]) || self.q.hermite.f.cell_missing(min[0], min[1], min[2])
            {
                return None; // no surface; a missing cell has none (`interpolant::cell_missing`)
            }
            let qef = self.q.cell_qef(min);
            let vertex = self.q.vertex(min);
            let manifold = one_piece(&s);
            return Some(self.push(Node::Leaf { min, size, qef, vertex, manifold, id: 0 }));
        }
        let half = size / 2;
        let children: [Option<usize>; 8] = std::array::from_fn(|c| {
            let o = bits(c);
            self.build([min[0] + o[0] * half, min[1] + o[1] * half, min[2] + o[2] * half], half)
        });
        if children.iter().all(Option::is_none) {
            return None;
        }
        match self.collapse(min, size, &children) {
            // The children stay in the arena, unreachable.
            Some(leaf) => Some(self.push(leaf)),
            None => Some(self.push(Node::Internal { children })),
        }
    }

    /// The leaf replacing `children` when the node may collapse (step 2 of the module docs).
    fn collapse(
        &self,
        min: [usize; 3],
        size: usize,
        children: &[Option<usize>; 8],
    ) -> Option<Node> {
        // Inside the grid, and off its faces: the surface is open at the grid's box, and a
        // leaf reaching the box would swallow the minimal edges the open border's quads hang
        // on (a plane through the box would collapse into one leaf and no quad).
        if (0..3).any(|a| min[a] == 0 || min[a] + size >= self.nc[a]) {
            return None;
        }
        let mut qef = Qef::default();
        for c in children.iter().flatten() {
            match &self.nodes[*c] {
                Node::Leaf { manifold: true, qef: q, .. } => qef = qef.merged(q),
                _ => return None,
            }
        }
        let s = self.signs(min, size);
        if !one_piece(&s) || !self.midpoints_agree(min, size, &s) || self.has_missing(min, size) {
            return None;
        }
        let lo = DVec3::new(min[0] as f64, min[1] as f64, min[2] as f64);
        let clamp = self.q.clamp.then_some((lo, lo + size as f64));
        let vertex = qef.solve(self.q.threshold, clamp);
        if qef.error(vertex) > self.limit {
            return None;
        }
        Some(Node::Leaf { min, size, qef, vertex, manifold: true, id: 0 })
    }

    /// Whether a point of the cube at `min` with side `size` is missing data: such a cube
    /// holds a missing cell (no leaf), so it never collapses into one leaf.
    fn has_missing(&self, min: [usize; 3], size: usize) -> bool {
        let f = self.q.hermite.f;
        (min[2]..=min[2] + size).any(|k| {
            (min[1]..=min[1] + size)
                .any(|j| (min[0]..=min[0] + size).any(|i| f.is_missing(i, j, k)))
        })
    }

    /// The sign at each edge midpoint, face centre and the centre of the cube is the sign of
    /// one of its corners.
    fn midpoints_agree(&self, min: [usize; 3], size: usize, s: &[bool; 8]) -> bool {
        let h = size / 2;
        let at =
            |o: [usize; 3]| self.inside([min[0] + o[0] * h, min[1] + o[1] * h, min[2] + o[2] * h]);
        // Every point of the 3×3×3 lattice of half steps that is not a corner: the corners
        // of the cube it lies on the edge, face or interior of are those whose coordinates
        // agree with it wherever it is at 0 or 2 (a corner) and are free where it is at 1.
        for z in 0..3 {
            for y in 0..3 {
                for x in 0..3 {
                    let o = [x, y, z];
                    if o.iter().all(|&c| c != 1) {
                        continue;
                    }
                    let v = at(o);
                    let any = (0..8).any(|c| {
                        let b = bits(c);
                        (0..3).all(|a| o[a] == 1 || o[a] == 2 * b[a]) && s[c] == v
                    });
                    if !any {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// Numbers the reachable leaves depth first and creates their vertices.
    fn number(&mut self, n: usize, verts: &mut Vertices) -> Result<(), MeshError> {
        let f = self.q.hermite.f;
        match &mut self.nodes[n] {
            Node::Leaf { vertex, id, .. } => {
                *id = verts.push(f, *vertex, DVec3::ZERO)?;
            }
            Node::Internal { children } => {
                let children = *children;
                for c in children.into_iter().flatten() {
                    self.number(c, verts)?;
                }
            }
        }
        Ok(())
    }
}

/// The inside corners of a cube are connected along its edges, and so are the outside ones.
fn one_piece(s: &[bool; 8]) -> bool {
    [true, false].iter().all(|&side| {
        let members: Vec<usize> = (0..8).filter(|&c| s[c] == side).collect();
        let Some(&first) = members.first() else {
            return true;
        };
        let mut seen = 1u8 << first;
        let mut grew = true;
        while grew {
            grew = false;
            for &c in &members {
                if seen & (1 << c) == 0 && [1, 2, 4].iter().any(|b| seen & (1 << (c ^ b)) != 0) {
                    seen |= 1 << c;
                    grew = true;
                }
            }
        }
        members.iter().all(|&c| seen & (1 << c) != 0)
    })
}

/// The adaptive mesh (see the module docs); `eps` in world units.
pub(crate) fn extract(q: &DcQef, eps: f64, budget: &MeshBudget) -> Result<Mesh, MeshError> {
    let f = q.hermite.f;
    let nc = f.dims.map(|n| n - 1);
    let mut size = 1;
    while size < nc.into_iter().max().unwrap_or(1) {
        size *= 2;
    }
    let s = f.spacing().max_element();
    let limit = (eps / s) * (eps / s);
    let mut t = Octree { q, nodes: Vec::new(), budget, over: None, nc, limit };
    let root = t.build([0; 3], size);
    if let Some(over) = t.over.take() {
        return Err(over);
    }
    let Some(root) = root else {
        return Ok(Mesh::default());
    };
    let mut verts = Vertices::default();
    t.number(root, &mut verts)?;
    let mut c = Contour { t: &t, indices: Vec::new() };
    c.cell(root);
    let indices = c.indices;
    to_u32(indices.len(), "indices")?;
    Ok(Mesh { positions: verts.positions, normals: verts.normals, indices, quads: None })
}

// The recursion's tables, in the crate's corner order (bit 0 = x, bit 1 = y, bit 2 = z). For
// a pair of cells sharing a face across `axis`, and for four cells around an edge along
// `axis`, they list which children meet at the shared face or edge.

/// The 12 pairs of children sharing a face inside a cell: (low child, high child, axis).
const CELL_FACES: [(usize, usize, usize); 12] = [
    (0, 1, 0),
    (2, 3, 0),
    (4, 5, 0),
    (6, 7, 0),
    (0, 2, 1),
    (1, 3, 1),
    (4, 6, 1),
    (5, 7, 1),
    (0, 4, 2),
    (1, 5, 2),
    (2, 6, 2),
    (3, 7, 2),
];

/// The cells around an edge along `axis`, in the order (b, c) = (0,0), (1,0), (1,1), (0,1)
/// of their offsets along `(axis + 1, axis + 2) mod 3` (counter-clockwise about +axis), as
/// corner bits of a cube's children.
fn ring(axis: usize, along: usize) -> [usize; 4] {
    let (b, c) = (1 << ((axis + 1) % 3), 1 << ((axis + 2) % 3));
    let a = along << axis;
    [a, a | b, a | b | c, a | c]
}

struct Contour<'t, 'q, 'f, 'g, 's, 'b> {
    t: &'t Octree<'q, 'f, 'g, 's, 'b>,
    indices: Vec<u32>,
}

impl Contour<'_, '_, '_, '_, '_, '_> {
    fn child(&self, n: usize, c: usize) -> Option<usize> {
        match &self.t.nodes[n] {
            Node::Leaf { .. } => Some(n),
            Node::Internal { children } => children[c],
        }
    }

    fn is_leaf(&self, n: usize) -> bool {
        matches!(self.t.nodes[n], Node::Leaf { .. })
    }

    fn cell(&mut self, n: usize) {
        let Node::Internal { children } = &self.t.nodes[n] else {
            return;
        };
        let children = *children;
        for c in children.into_iter().flatten() {
            self.cell(c);
        }
        for (lo, hi, axis) in CELL_FACES {
            if let (Some(a), Some(b)) = (children[lo], children[hi]) {
                self.face([a, b], axis);
            }
        }
        for axis in 0..3 {
            // The edge along `axis` through the cell's centre: the 4 children around it, at
            // both halves along the axis.
            for along in 0..2 {
                let r = ring(axis, along).map(|c| children[c]);
                if let [Some(a), Some(b), Some(c), Some(d)] = r {
                    self.edge([a, b, c, d], axis);
                }
            }
        }
    }

    /// Two cells sharing a face across `axis` (`n[0]` on the low side).
    fn face(&mut self, n: [usize; 2], axis: usize) {
        if self.is_leaf(n[0]) && self.is_leaf(n[1]) {
            return;
        }
        let (b, c) = (1 << ((axis + 1) % 3), 1 << ((axis + 2) % 3));
        let x = 1 << axis;
        // The 4 pairs of children across the face.
        for m in [0, b, c, b | c] {
            if let (Some(p), Some(q)) = (self.child(n[0], m | x), self.child(n[1], m)) {
                self.face([p, q], axis);
            }
        }
        // The 4 edges in the face: along the two other axes, through the face's centre. Seen
        // as the children of a cube straddling the face, the 4 cells around such an edge are
        // its ring; ring position `bits` lies in the face cell on side `bits`'s bit along
        // `axis`, as that cell's child on the face (bit along `axis` flipped).
        for e_axis in [(axis + 1) % 3, (axis + 2) % 3] {
            for along in 0..2 {
                let r = ring(e_axis, along).map(|bits| {
                    let side = (bits >> axis) & 1;
                    self.child(n[side], bits ^ x)
                });
                if let [Some(p), Some(q), Some(r2), Some(s)] = r {
                    self.edge([p, q, r2, s], e_axis);
                }
            }
        }
    }

    /// Four cells around an edge along `axis`, in ring order.
    fn edge(&mut self, n: [usize; 4], axis: usize) {
        if n.iter().all(|&x| self.is_leaf(x)) {
            self.quad(n, axis);
            return;
        }
        // Cell k of the ring touches the edge with its child diagonally opposite its ring
        // position; the edge splits in two along the axis.
        let r = ring(axis, 0);
        for along in 0..2 {
            let kids = std::array::from_fn(|k| {
                let opposite = r[(k + 2) % 4] | (along << axis);
                self.child(n[k], opposite)
            });
            if let [Some(a), Some(b), Some(c), Some(d)] = kids {
                self.edge([a, b, c, d], axis);
            }
        }
    }

    /// The minimal edge shared by 4 leaves: its quad if it is crossed.
    fn quad(&mut self, n: [usize; 4], axis: usize) {
        // The smallest leaf holds the minimal edge: corner bits of that edge in leaf k are
        // those diagonally opposite k's ring position.
        let r = ring(axis, 0);
        let mut best = (usize::MAX, 0);
        let mut ids = [0u32; 4];
        for k in 0..4 {
            let Node::Leaf { size, id, .. } = &self.t.nodes[n[k]] else {
                return;
            };
            ids[k] = *id;
            if *size < best.0 {
                best = (*size, k);
            }
        }
        let k = best.1;
        let Node::Leaf { min, size, .. } = &self.t.nodes[n[k]] else {
            return;
        };
        let start = r[(k + 2) % 4];
        let o = bits(start);
        let a = [min[0] + o[0] * size, min[1] + o[1] * size, min[2] + o[2] * size];
        let mut b = a;
        b[axis] += size;
        let (ia, ib) = (self.t.inside(a), self.t.inside(b));
        if ia == ib {
            return;
        }
        // Ring order is counter-clockwise about +axis: the surface faces +axis when the
        // start point is inside, so keep the order then, else reverse.
        let mut q = ids;
        if !ia {
            q.swap(1, 3);
        }
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            if t[0] != t[1] && t[1] != t[2] && t[2] != t[0] {
                self.indices.extend_from_slice(&t);
            }
        }
    }
}
