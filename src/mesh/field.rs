//! The sampled field as the extractors see it: values in f64, the inside rule, crossing points,
//! index-space → world-space mapping and trilinear gradients (all in index space unless named
//! `world`).

use glam::DVec3;

use super::lanes::{self, F64x4, LANES};
use crate::field::interpolant::trilinear::gradient_in;
use crate::field::interpolant::{is_missing, Kernel, Trilinear};
use crate::field::Grid;
use crate::vocab::Inside;

/// The flag of a missing sample ([`is_missing`]) in [`Field::inside_flags`], beside 1 (inside)
/// and 0 (outside): a cell with such a corner is missing and an edge with such an end is never
/// crossed (see [`crate::field::interpolant::cell_missing`]).
pub(crate) const MISSING: u8 = 2;

pub(crate) struct Field<'a> {
    /// The samples held: point layers `first..first + grid.dims[2]` of the whole grid (all
    /// of it unless this is a window, see `window`).
    grid: &'a Grid,
    /// The first point layer `grid` holds.
    first: usize,
    pub iso: f64,
    pub inside: Inside,
    /// Points of the whole grid, which every index (`i, j, k`, index-space `u`) refers to.
    pub dims: [usize; 3],
    /// World-space corner of the whole grid's point (0, 0, 0).
    min: DVec3,
    /// World-space size of one cell.
    spacing: DVec3,
    /// Set when `grid` is a refined lattice of another interpolant's values
    /// ([`super::refine`]): crossings and normals are then that interpolant's own.
    exact: Option<&'a super::refine::Exact<'a>>,
}

/// The crossing parameter `s` on an edge from value `a` to value `b` (see the module docs of
/// `mesh`): `(iso - a) / (b - a)` clamped to `[0, 1]`, 0.5 when that is NaN.
pub(crate) fn crossing(a: f64, b: f64, iso: f64) -> f64 {
    let s = (iso - a) / (b - a);
    if s.is_nan() {
        0.5
    } else {
        s.clamp(0.0, 1.0)
    }
}

impl<'a> Field<'a> {
    pub fn new(grid: &'a Grid, iso: f64, inside: Inside) -> Self {
        Field {
            grid,
            first: 0,
            iso,
            inside,
            dims: grid.dims,
            min: grid.min,
            spacing: grid.spacing(),
            exact: None,
        }
    }

    /// The field of the refined lattice `grid` whose crossings and normals are `exact`'s
    /// ([`super::refine`]).
    pub fn refined(
        grid: &'a Grid,
        exact: &'a super::refine::Exact<'a>,
        iso: f64,
        inside: Inside,
    ) -> Self {
        Field { exact: Some(exact), ..Field::new(grid, iso, inside) }
    }

    /// The field of the whole grid `lattice` of which `grid` holds the point layers
    /// `first..first + grid.dims[2]` (its x and y extents are the whole grid's). Indices stay
    /// the whole grid's, so the arithmetic, and every result, is the whole grid's bit for bit;
    /// reading a point layer outside the window panics (an index out of bounds), which the
    /// window tests rely on to prove `window::point_layers` holds enough.
    pub fn window(
        grid: &'a Grid,
        first: usize,
        lattice: &super::window::Lattice,
        iso: f64,
        inside: Inside,
    ) -> Self {
        debug_assert_eq!(grid.dims[..2], lattice.dims[..2]);
        let (dims, min, spacing) = (lattice.dims, lattice.min, lattice.spacing());
        Field { grid, first, iso, inside, dims, min, spacing, exact: None }
    }

    /// Whether crossings and normals are another interpolant's ([`Field::refined`]), not the
    /// trilinear cells' own.
    pub fn is_refined(&self) -> bool {
        self.exact.is_some()
    }

    /// World-space corner of the whole grid's point (0, 0, 0).
    pub fn min(&self) -> DVec3 {
        self.min
    }

    /// Linear index of point `(i, j, k)` in the whole grid.
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Index into the held samples of point `(i, j, k)` of the whole grid.
    fn held(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * (k - self.first))
    }

    /// Sample at point `(i, j, k)`, widened to f64.
    pub fn value(&self, i: usize, j: usize, k: usize) -> f64 {
        f64::from(self.grid.values[self.held(i, j, k)])
    }

    /// The held samples of point layer `k` of the whole grid, x fastest.
    pub fn layer(&self, k: usize) -> &'a [f32] {
        let n = self.dims[0] * self.dims[1];
        &self.grid.values[(k - self.first) * n..][..n]
    }

    /// The inside rule at each of `values` as 1 or 0, or [`MISSING`], into `out` (resized to
    /// match).
    pub fn inside_flags(&self, values: &[f32], out: &mut Vec<u8>) {
        out.clear();
        out.extend(values.iter().map(|&v| {
            let v = f64::from(v);
            if is_missing(v) {
                MISSING
            } else {
                u8::from(self.inside.contains(v, self.iso))
            }
        }));
    }

    /// Whether the sample at point `(i, j, k)` is missing data.
    pub fn is_missing(&self, i: usize, j: usize, k: usize) -> bool {
        is_missing(self.value(i, j, k))
    }

    /// Whether cell `(i, j, k)` is missing (a corner is missing data): it holds no surface.
    pub fn cell_missing(&self, i: usize, j: usize, k: usize) -> bool {
        Trilinear::missing(&self.corners(i, j, k))
    }

    /// The inside rule at point `(i, j, k)`.
    pub fn is_inside(&self, i: usize, j: usize, k: usize) -> bool {
        self.inside.contains(self.value(i, j, k), self.iso)
    }

    /// Corner values of cell `(i, j, k)` in f64.
    pub fn corners(&self, i: usize, j: usize, k: usize) -> [f64; 8] {
        // The 8 loads addressed from one base (the extractors call this for every vertex's
        // normal); the values are `Grid::corners`'s.
        let [nx, ny, _] = self.dims;
        let p = self.held(i, j, k);
        let (y, z) = (nx, nx * ny);
        let v = &self.grid.values[p..=p + z + y + 1];
        [v[0], v[1], v[y], v[y + 1], v[z], v[z + 1], v[z + y], v[z + y + 1]].map(f64::from)
    }

    /// Bitmask of the inside corners of cell `(i, j, k)`: bit `n` for corner `n`.
    pub fn corner_mask(&self, i: usize, j: usize, k: usize) -> u8 {
        let mut mask = 0u8;
        for (n, &v) in self.corners(i, j, k).iter().enumerate() {
            if self.inside.contains(v, self.iso) {
                mask |= 1 << n;
            }
        }
        mask
    }

    /// The crossing parameter on the edge from value `a` to value `b`.
    pub fn crossing(&self, a: f64, b: f64) -> f64 {
        crossing(a, b, self.iso)
    }

    /// The crossing parameter on the lattice edge from point `start` to `start + d`, whose
    /// samples are `a` and `b`: [`Field::crossing`] of the two values, or on a refined
    /// lattice the interpolant's own crossing on the edge ([`super::refine::Exact::crossing`]).
    #[inline]
    pub fn crossing_on(&self, start: [usize; 3], d: [usize; 3], a: f64, b: f64) -> f64 {
        match self.exact {
            None => self.crossing(a, b),
            Some(e) => {
                e.crossing(start, d, self.iso, self.inside).unwrap_or_else(|| self.crossing(a, b))
            }
        }
    }

    /// World-space position of index-space point `u`.
    pub fn world_f64(&self, u: DVec3) -> DVec3 {
        self.min + u * self.spacing
    }

    /// World-space size of one cell.
    pub fn spacing(&self) -> DVec3 {
        self.spacing
    }

    /// World-space position of index-space point `u`, rounded to f32.
    pub fn world(&self, u: DVec3) -> [f32; 3] {
        let p = self.min + u * self.spacing;
        [p.x as f32, p.y as f32, p.z as f32]
    }

    /// The unit normal (inside → outside, world space) at index-space point `u`: the mean of the
    /// trilinear gradients of every cell that contains `u`, divided by the spacing, negated for
    /// `inside = above`. `fallback` (an index-space direction, inside → outside) is used where
    /// that gradient vanishes.
    pub fn normal(&self, u: DVec3, fallback: DVec3) -> [f32; 3] {
        if let Some(e) = self.exact {
            return self.normal_from(e.gradient(u) * self.spacing, fallback);
        }
        self.normal_from(self.gradient(u), fallback)
    }

    /// [`Field::normal`] at `u`, which lies strictly inside the trilinear cell whose corner
    /// values are `v` (in [`Field::corners`]' order) and whose corner 0 is at index-space `lo`:
    /// the same bits, without the search for the cells around `u` (one cell here, the one
    /// [`Field::gradient`] would pick, with the same local coordinates and the same sum). Not
    /// for a refined field, whose normals are not the cells' ([`Field::is_refined`]).
    pub fn normal_in_corners(
        &self,
        v: &[f64; 8],
        lo: DVec3,
        u: DVec3,
        fallback: DVec3,
    ) -> [f32; 3] {
        debug_assert!(self.exact.is_none());
        debug_assert!(
            u.cmpgt(lo).all() && u.cmplt(lo + 1.0).all(),
            "{u} not inside the cell at {lo}"
        );
        match self.unit_in_corners(v, lo, u) {
            Some(n) => n,
            None => self.fallback_normal(fallback),
        }
    }

    /// [`Field::normal_in_corners`] where the gradient gives the normal; None where the
    /// fallback would apply (the gradient vanishes or is not finite). The extractors that
    /// compute many normals in a row call this for each and the fallback for the few Nones.
    #[inline(always)]
    pub fn unit_in_corners(&self, v: &[f64; 8], lo: DVec3, u: DVec3) -> Option<[f32; 3]> {
        let l = u - lo;
        // `gradient`'s mean over one cell: the sum from zero, divided by 1.
        let g = (DVec3::ZERO + Trilinear::gradient(v, l)) / 1.0;
        self.unit_from(g)
    }

    /// [`Field::unit_in_corners`] of [`LANES`] points at once, each lane the scalar's bits:
    /// the corner values `v`, the cells' corner 0 `lo` and the points `u` lane by lane; the
    /// normals rounded to f32, and per lane whether the gradient gave it (false where the
    /// fallback applies).
    #[inline(always)]
    pub fn units_in_corners(
        &self,
        v: &[F64x4; 8],
        lo: [F64x4; 3],
        u: [F64x4; 3],
    ) -> ([[f32; 3]; LANES], [bool; LANES]) {
        let l = [u[0] - lo[0], u[1] - lo[1], u[2] - lo[2]];
        let (zero, one) = (F64x4::splat(0.0), F64x4::splat(1.0));
        // The sum from zero; `/ 1.0` leaves every lane as it is.
        let g = gradient_in(v, l[0], l[1], l[2], one).map(|g| zero + g);
        // `unit_from`, lane by lane.
        let sign = F64x4::splat(match self.inside {
            Inside::Below => 1.0,
            Inside::Above => -1.0,
        });
        let sp = self.spacing.to_array().map(F64x4::splat);
        let g = [sign * g[0] / sp[0], sign * g[1] / sp[1], sign * g[2] / sp[2]];
        let ls = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
        let r = one / ls.sqrt();
        let n = g.map(|g| (g * r).to_f32());
        let finite = g.map(F64x4::is_finite);
        let ok = lanes::and(ls.gt(zero), lanes::and(finite[0], lanes::and(finite[1], finite[2])));
        (std::array::from_fn(|i| [n[0][i], n[1][i], n[2][i]]), ok)
    }

    /// The unit normal from the index-space gradient `g` at a point (see [`Field::normal`]).
    fn normal_from(&self, g: DVec3, fallback: DVec3) -> [f32; 3] {
        match self.unit_from(g) {
            Some(n) => n,
            None => self.fallback_normal(fallback),
        }
    }

    /// [`Field::normal_from`] where the gradient `g` gives the normal, else None.
    #[inline(always)]
    fn unit_from(&self, g: DVec3) -> Option<[f32; 3]> {
        let sign = match self.inside {
            Inside::Below => 1.0,
            Inside::Above => -1.0,
        };
        let g = sign * g / self.spacing;
        // `g.normalize()`'s arithmetic, computed before the test without glam's assertion.
        let n = g * (1.0 / g.length());
        (g.length_squared() > 0.0 && g.is_finite()).then_some([n.x as f32, n.y as f32, n.z as f32])
    }

    /// The normal where the gradient gives none: the index-space direction `fallback` (inside
    /// → outside), else +z.
    fn fallback_normal(&self, fallback: DVec3) -> [f32; 3] {
        let f = fallback * self.spacing;
        let n = if f.length_squared() > 0.0 && f.is_finite() { f.normalize() } else { DVec3::Z };
        [n.x as f32, n.y as f32, n.z as f32]
    }

    /// Index-space gradient at `u`, averaged over the cells containing `u`: along each axis, a
    /// coordinate strictly between cells' integer boundaries selects one cell; an integer
    /// coordinate inside the grid selects the two cells that share that plane. Missing cells
    /// are left out (a vertex of a finite cell beside one takes its finite cells' mean; with
    /// none, the result is NaN and the callers' fallback applies).
    pub fn gradient(&self, u: DVec3) -> DVec3 {
        let mut choices = [[(0usize, 0.0f64); 2]; 3];
        let mut counts = [0usize; 3];
        for a in 0..3 {
            let cells = self.dims[a] - 1;
            let ua = u[a];
            let fl = ua.floor();
            if ua == fl && fl > 0.0 && (fl as usize) < cells {
                let c = fl as usize;
                choices[a] = [(c - 1, 1.0), (c, 0.0)];
                counts[a] = 2;
            } else {
                let c = (fl.max(0.0) as usize).min(cells - 1);
                choices[a][0] = (c, ua - c as f64);
                counts[a] = 1;
            }
        }
        let mut sum = DVec3::ZERO;
        let mut n = 0.0;
        for &(cz, lz) in &choices[2][..counts[2]] {
            for &(cy, ly) in &choices[1][..counts[1]] {
                for &(cx, lx) in &choices[0][..counts[0]] {
                    let v = self.corners(cx, cy, cz);
                    if Trilinear::missing(&v) {
                        continue;
                    }
                    sum += Trilinear::gradient(&v, DVec3::new(lx, ly, lz));
                    n += 1.0;
                }
            }
        }
        sum / n
    }
}
