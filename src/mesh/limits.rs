//! The mesh memory cap ([`MeshLimits`]) and the running count that enforces it while a mesh is
//! built ([`MeshBudget`]).
//!
//! A mesh's size is not known before it is extracted (a noisy 256³ grid makes 53 million
//! triangles, 1.3 GB), so the cap cannot be checked up front as the grid cap is: the
//! extraction adds every slab's vertices and indices to a [`MeshBudget`] as the slab is done
//! and stops with [`MeshError::OverCap`] once the total passes the cap, before the slabs are
//! joined. The bytes counted are what the finished [`super::Mesh`] holds: 24 per vertex (f32
//! position and normal) and 4 per triangle or quad index.

use std::sync::atomic::{AtomicU64, Ordering};

use super::MeshError;

/// Environment variable that sets the mesh memory cap, in MiB.
pub const MESH_CAP_ENV: &str = "ISOVIEW_MAX_MESH_MIB";

/// Bytes a mesh holds per vertex: f32 position and normal.
pub const VERTEX_BYTES: u64 = 24;
/// Bytes a mesh holds per index (of a triangle or a quad).
pub const INDEX_BYTES: u64 = 4;
/// Bytes of a vertex's position alone (what `--stats` of a streamed mesh holds).
pub const POSITION_BYTES: u64 = 12;

/// The most a mesh being extracted may hold in memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshLimits {
    /// Most bytes of vertices and indices (see the module documentation).
    pub max_bytes: u64,
}

impl Default for MeshLimits {
    /// 1024 MiB: the grid cap's default (`GridLimits`), about 44 million marching-cubes
    /// triangles.
    fn default() -> Self {
        MeshLimits { max_bytes: crate::field::GridLimits::DEFAULT_MAX_BYTES }
    }
}

impl MeshLimits {
    /// No cap (library callers that bound their meshes themselves).
    pub const UNLIMITED: MeshLimits = MeshLimits { max_bytes: u64::MAX };

    /// The cap from `ISOVIEW_MAX_MESH_MIB` (a positive whole number of MiB), or the default
    /// when the variable is unset or empty.
    pub fn from_env() -> Result<MeshLimits, MeshError> {
        match std::env::var(MESH_CAP_ENV) {
            Err(std::env::VarError::NotPresent) => Ok(MeshLimits::default()),
            Err(std::env::VarError::NotUnicode(v)) => {
                Err(MeshError::BadLimit { value: v.to_string_lossy().into_owned() })
            }
            Ok(v) if v.trim().is_empty() => Ok(MeshLimits::default()),
            Ok(v) => Self::from_mib_str(&v),
        }
    }

    /// Parses a cap written in MiB (as in `ISOVIEW_MAX_MESH_MIB`).
    pub fn from_mib_str(text: &str) -> Result<MeshLimits, MeshError> {
        text.trim()
            .parse::<u64>()
            .ok()
            .filter(|&m| m > 0)
            .and_then(|m| m.checked_mul(1 << 20))
            .map(|max_bytes| MeshLimits { max_bytes })
            .ok_or_else(|| MeshError::BadLimit { value: text.to_string() })
    }

    /// Bytes of a mesh of `vertices` vertices and `indices` triangle and quad indices.
    pub fn bytes(vertices: u64, indices: u64) -> u64 {
        vertices.saturating_mul(VERTEX_BYTES).saturating_add(indices.saturating_mul(INDEX_BYTES))
    }
}

/// What a mesh being built holds so far, checked against a cap at every addition. Shared by
/// the threads that extract slabs (the counts are atomic) and by the surfaces of one scene,
/// whose meshes are held together until they are written.
#[derive(Debug)]
pub struct MeshBudget {
    limits: MeshLimits,
    vertices: AtomicU64,
    triangles: AtomicU64,
    bytes: AtomicU64,
}

impl Default for MeshBudget {
    /// Without a cap.
    fn default() -> Self {
        Self::unlimited()
    }
}

impl MeshBudget {
    pub fn new(limits: MeshLimits) -> Self {
        MeshBudget {
            limits,
            vertices: AtomicU64::new(0),
            triangles: AtomicU64::new(0),
            bytes: AtomicU64::new(0),
        }
    }

    /// A budget without a cap.
    pub fn unlimited() -> Self {
        Self::new(MeshLimits::UNLIMITED)
    }

    /// Counts `vertices` more vertices, `triangles` more triangles and `quad_indices` more quad
    /// indices; [`MeshError::OverCap`] with the totals so far once they pass the cap.
    pub fn add(
        &self,
        vertices: usize,
        triangles: usize,
        quad_indices: usize,
    ) -> Result<(), MeshError> {
        let (v, t) = (vertices as u64, triangles as u64);
        let b = MeshLimits::bytes(v, t.saturating_mul(3).saturating_add(quad_indices as u64));
        self.count(v, t, b)
    }

    /// Counts the positions of `vertices` more vertices (and `triangles` more triangles, for
    /// the message): what is held of a mesh written piece by piece whose statistics are wanted.
    pub fn add_positions(&self, vertices: usize, triangles: usize) -> Result<(), MeshError> {
        let v = vertices as u64;
        self.count(v, triangles as u64, v.saturating_mul(POSITION_BYTES))
    }

    /// Adds `v` vertices, `t` triangles and `b` bytes; past the cap, the totals as the error.
    fn count(&self, v: u64, t: u64, b: u64) -> Result<(), MeshError> {
        let vertices = self.vertices.fetch_add(v, Ordering::Relaxed).saturating_add(v);
        let triangles = self.triangles.fetch_add(t, Ordering::Relaxed).saturating_add(t);
        let bytes = self.bytes.fetch_add(b, Ordering::Relaxed).saturating_add(b);
        if bytes > self.limits.max_bytes {
            return Err(MeshError::OverCap {
                vertices,
                triangles,
                bytes,
                cap: self.limits.max_bytes,
            });
        }
        Ok(())
    }

    /// Whether a method that is not cut into slabs may hold `bytes` more while it works (its
    /// own tables besides the mesh so far), beside what the budget has counted:
    /// [`MeshError::WorkOverCap`] when that passes the cap. Nothing is counted: the mesh it
    /// makes is counted when it is done.
    pub fn check_working(
        &self,
        method: &'static str,
        what: &'static str,
        bytes: u64,
    ) -> Result<(), MeshError> {
        let held = self.bytes.load(Ordering::Relaxed).saturating_add(bytes);
        if held > self.limits.max_bytes {
            return Err(MeshError::WorkOverCap {
                method,
                what,
                bytes: held,
                cap: self.limits.max_bytes,
            });
        }
        Ok(())
    }

    /// [`MeshBudget::add`] of a whole mesh.
    pub fn add_mesh(&self, mesh: &super::Mesh) -> Result<(), MeshError> {
        let quads = mesh.quads.as_ref().map_or(0, Vec::len);
        self.add(mesh.vertex_count(), mesh.triangle_count(), quads)
    }
}

/// A byte count for [`MeshError::OverCap`]'s message: `1024 MiB`, `1.05 MiB` (rounded to a
/// whole number of MiB it could read as the cap itself).
pub(crate) fn mib(bytes: u64) -> String {
    const MIB: u64 = 1 << 20;
    if bytes % MIB == 0 {
        format!("{} MiB", bytes / MIB)
    } else {
        format!("{:.2} MiB", bytes as f64 / MIB as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_mib_and_refuses_the_rest() {
        assert_eq!(MeshLimits::from_mib_str(" 3 ").unwrap().max_bytes, 3 << 20);
        for bad in ["0", "-1", "lots", "1.5", ""] {
            let e = MeshLimits::from_mib_str(bad).unwrap_err().to_string();
            assert!(e.starts_with("ISOVIEW_MAX_MESH_MIB=") && e.contains("positive whole"), "{e}");
        }
    }

    #[test]
    fn the_budget_refuses_once_the_total_passes_the_cap_with_the_totals() {
        // 1 MiB: 30,000 vertices (720,000 bytes) fit, 30,000 more triangles (360,000) do not.
        let budget = MeshBudget::new(MeshLimits { max_bytes: 1 << 20 });
        budget.add(30_000, 0, 0).unwrap();
        let e = budget.add(0, 30_000, 0).unwrap_err();
        match e {
            MeshError::OverCap { vertices, triangles, bytes, cap } => {
                assert_eq!((vertices, triangles, bytes, cap), (30_000, 30_000, 1_080_000, 1 << 20))
            }
            other => panic!("{other}"),
        }
        let text = e.to_string();
        assert!(text.contains("30000 triangles") && text.contains("(1.03 MiB of"), "{text}");
        assert!(text.contains("over the cap of 1 MiB;"), "{text}");
        assert!(text.contains("ISOVIEW_MAX_MESH_MIB"), "{text}");
        assert!(MeshBudget::unlimited().add(usize::MAX, usize::MAX, usize::MAX).is_ok());
    }
}
