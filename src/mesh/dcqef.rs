//! `dual-contouring-qef`: dual contouring of Hermite data (Ju, Losasso, Schaefer & Warren
//! 2002). The cells, quads, numbering, padding and quad split are `dual-contouring`'s
//! (`dual.rs`, closed at the grid's box as GEL does); only the vertex of a cell of the grid
//! moves, from the mean of its crossings to the minimiser of the QEF of its crossed edges'
//! tangent planes (`qef.rs`, Hermite data from `hermite.rs`):
//!
//! ```text
//!     mean of crossings (surface nets)        QEF minimiser (this)
//!        ╲     ·                                 ╲     ·
//!         ╲  ·   ●  ← rounds the corner           ╲  ·
//!          ╲·                                      ●──────  ← on both planes: the corner
//!     ──────×──────                           ──────×──────
//! ```
//!
//! Padding cells (outside the grid's box) keep `dual-contouring`'s vertex, pinned to the box
//! face, so the mesh is closed the same way.
//!
//! Rules: the planes of grid cell `c` are added in `dual.rs`'s edge order (x edges, y edges,
//! z edges; within axis `a` by the offsets along `(a+1, a+2) mod 3`: (0,0), (1,0), (0,1),
//! (1,1)); the vertex is [`Qef::solve`] with `render.qef_threshold`, clamped into the cell
//! when `render.qef_clamp`; the vertex normal is the field's at the vertex clamped into its
//! cell (the same point when clamping).

use glam::DVec3;

use super::hermite::Hermite;
use super::qef::Qef;

/// The vertex rule of `dual-contouring-qef`.
pub(crate) struct DcQef<'f, 'g, 's> {
    pub hermite: Hermite<'f, 'g, 's>,
    pub threshold: f64,
    pub clamp: bool,
}

impl DcQef<'_, '_, '_> {
    /// The QEF of grid cell `c`'s crossed edges (index space).
    pub fn cell_qef(&self, c: [usize; 3]) -> Qef {
        let mut q = Qef::default();
        for axis in 0..3 {
            let (b, cc) = ((axis + 1) % 3, (axis + 2) % 3);
            for m in 0..4 {
                let mut p = c;
                p[b] += m & 1;
                p[cc] += m >> 1;
                if let Some((u, n)) = self.hermite.edge(p, axis) {
                    q.add(u, n);
                }
            }
        }
        q
    }

    /// The vertex of grid cell `c` (index space), which must be active.
    pub fn vertex(&self, c: [usize; 3]) -> DVec3 {
        let lo = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        let clamp = self.clamp.then_some((lo, lo + 1.0));
        self.cell_qef(c).solve(self.threshold, clamp)
    }
}
