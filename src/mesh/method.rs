//! The extraction methods (`render.mesh`): every fact isoview knows about each, in one row.
//!
//! Every place that treats methods differently asks the method's [`Method`] row instead of
//! matching on [`MeshAlgorithm`]: the padding of the cell lattice, whether it makes quads, reads
//! the sharp-feature settings or builds an adaptive octree, which GPU passes run it and when
//! they do not (the one CPU-instead rule, [`Method::cpu_instead`]), and why it is not cut into
//! z-ranges or streamed. The only match on the enum is [`MeshAlgorithm::method`], with no
//! catch-all arm, so a new variant without a row does not compile.
//!
//! Adding a method: a variant, its place in [`MeshAlgorithm::ALL`], its row and the arm in
//! [`MeshAlgorithm::method`] here, its module `mesh/<name>.rs`, and its tests
//! (docs/contributing.md "Adding things").

use std::ops::Range;

use super::field::Field;
use super::slabs::Part;
use super::{
    dcqef, dual, emc, hermite, mc, mc33, mt, nets, octree, Mesh, MeshBudget, MeshError, Request,
};
use crate::field::PointField;
use crate::vocab::{HermiteNormals, SharpSettings};

/// `render.mesh`: the extraction method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshAlgorithm {
    MarchingCubes,
    Mc33,
    SurfaceNets,
    DualContouring,
    MarchingTetrahedra,
    /// Dual contouring of Hermite data (Ju et al. 2002): one vertex per active cell at the
    /// minimiser of its edge planes' quadratic error function (`mesh/dcqef.rs`).
    DualContouringQef,
    /// Kobbelt et al.'s feature-sensitive marching cubes (2001) (`mesh/emc.rs`).
    ExtendedMc,
}

impl MeshAlgorithm {
    /// Every algorithm, in the order the contract lists them.
    pub const ALL: [MeshAlgorithm; 7] = [
        MeshAlgorithm::MarchingCubes,
        MeshAlgorithm::Mc33,
        MeshAlgorithm::SurfaceNets,
        MeshAlgorithm::DualContouring,
        MeshAlgorithm::MarchingTetrahedra,
        MeshAlgorithm::DualContouringQef,
        MeshAlgorithm::ExtendedMc,
    ];

    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        self.method().name
    }

    /// The method's row. The one match on the enum: no catch-all arm, so a variant without a
    /// row is a compile error.
    pub fn method(self) -> &'static Method {
        match self {
            MeshAlgorithm::MarchingCubes => &MARCHING_CUBES,
            MeshAlgorithm::Mc33 => &MC33,
            MeshAlgorithm::SurfaceNets => &SURFACE_NETS,
            MeshAlgorithm::DualContouring => &DUAL_CONTOURING,
            MeshAlgorithm::MarchingTetrahedra => &MARCHING_TETRAHEDRA,
            MeshAlgorithm::DualContouringQef => &DUAL_CONTOURING_QEF,
            MeshAlgorithm::ExtendedMc => &EXTENDED_MC,
        }
    }
}

/// How the GPU extraction passes (`passes::extract`) run a method: plain data, from which the
/// passes build their plan (`passes::extract::plan::Kind::of`); `mesh` knows no GPU code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuPasses {
    /// Vertices on the x/y/z lattice edges, triangles per cell from Bourke's table.
    MarchingCubes,
    /// Vertices on the 7 edge families, 6 tetrahedra per cell.
    Tetrahedra,
    /// As marching cubes, the cell's topology decided in f64, added vertices per cell.
    Mc33,
    /// Vertices per cell, quads per lattice edge (the padding: [`Method::padding`]).
    Dual,
}

/// Why a method asked for on the GPU is extracted on the CPU instead: the one rule for
/// `isoview extract`, `render.method = "mesh"` and the extraction driver's own refusal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CpuInstead {
    /// No GPU passes for it; `with`: the settings that turn them off ("" when it has none).
    NoPasses { with: &'static str },
    /// Its passes need 64-bit floats (shaderFloat64), which the device lacks.
    NoFloat64,
}

impl CpuInstead {
    /// The note `isoview extract` prints when it extracts `m` on the CPU for this reason on
    /// the Vulkan device named `device`.
    pub fn note(self, m: &Method, device: &str) -> String {
        let name = m.name;
        match self {
            CpuInstead::NoPasses { with } => {
                format!(
                    "note: {name} is extracted on the CPU (no GPU extraction passes for it{with})"
                )
            }
            CpuInstead::NoFloat64 => format!(
                "note: {name} is extracted on the CPU ({device} has no 64-bit floats, which the \
                 GPU {name} passes need)"
            ),
        }
    }
}

/// One method's facts (one row per [`MeshAlgorithm`]).
pub struct Method {
    pub algo: MeshAlgorithm,
    /// The name as written in scene files.
    pub name: &'static str,
    /// Layers of outside points padded around the grid on every side (dual contouring's
    /// closed boundary: 1), so its cell lattice has `n - 1 + 2 * padding` cells per axis.
    pub padding: usize,
    /// Makes quads (`ExtractOptions::keep_quads`, `--quads`, `Mesh::quads`).
    pub quads: bool,
    /// Reads the sharp-feature settings (`render.hermite`, `qef_threshold`, `qef_clamp`,
    /// `feature_angle`); its GPU passes get the QEF flags in `ExtractParams::iso_bits`.
    pub sharp: bool,
    /// `render.mesh_error` builds its adaptive octree; scene validation refuses the key for
    /// the other methods.
    pub adaptive: bool,
    /// Its vertices come from lattice-edge crossings alone (`Field::crossing_on`) and its
    /// topology from the points' inside flags, so it meshes any interpolant, on the lattice
    /// that `render.mesh_refine` refines (`mesh::refine`); mc33 decides a cell's topology from
    /// its trilinear interpolant and the sharp methods read trilinear Hermite data, so they
    /// mesh trilinear cells at `mesh_refine = 1` only.
    pub lattice_edges: bool,
    /// Its GPU passes; None: CPU only.
    pub gpu: Option<GpuPasses>,
    /// Its GPU passes need 64-bit floats (shaderFloat64): mc33 decides topology in f64.
    pub gpu_float64: bool,
    /// The settings under which its GPU passes do not apply, worded to follow "no GPU
    /// extraction passes for it"; None: they apply.
    pub gpu_off: fn(&SharpSettings) -> Option<&'static str>,
    /// Why these settings keep it from being cut into z-ranges (threads, MPI ranks, files
    /// read in windows); None: it is cut.
    pub not_in_slabs: fn(&SharpSettings) -> Option<&'static str>,
    /// Why its slabs, though cut, are not handed out as pieces one by one
    /// (`mesh::extract_streamed`); None: they are.
    pub not_streamed: Option<&'static str>,
    /// The f64 reference: the whole grid on one thread.
    /// The whole mesh at once; `extended-mc` checks its working memory against the budget's
    /// cap as it goes, the others ignore it (they are counted once done, or in slabs).
    pub(crate) reference: fn(&Field, &Request, &MeshBudget) -> Result<Mesh, MeshError>,
    /// Its slab code, for the threaded, z-range and streamed extractions (equal to the
    /// reference bit for bit once joined); None: never cut into slabs, and then
    /// [`Method::not_in_slabs`] always says why.
    pub(crate) slab: Option<SlabMaker>,
}

/// A slab of cell layers as a method extracts it, ready to run on any thread (state such as
/// the QEF rule built once and moved in).
pub(crate) type SlabFn<'a> = Box<dyn Fn(Range<usize>) -> Result<Part, MeshError> + Sync + 'a>;

/// Builds a method's [`SlabFn`] for a field and its settings.
pub(crate) type SlabMaker =
    for<'a> fn(&'a Field<'a>, &'a Request<'a>) -> Result<SlabFn<'a>, MeshError>;

impl Method {
    /// Why this method is extracted on the CPU when the GPU is asked for, with `sharp` on a
    /// device with (`float64`) or without 64-bit floats; None: its GPU passes run it.
    pub fn cpu_instead(&self, sharp: &SharpSettings, float64: bool) -> Option<CpuInstead> {
        if self.gpu.is_none() {
            return Some(CpuInstead::NoPasses { with: "" });
        }
        if let Some(with) = (self.gpu_off)(sharp) {
            return Some(CpuInstead::NoPasses { with });
        }
        (self.gpu_float64 && !float64).then_some(CpuInstead::NoFloat64)
    }

    /// The methods whose rows say `which`, named as in scene files: `"a"`, `"a" or "b"`,
    /// `"a", "b" or "c"` (for messages).
    pub fn names_where(which: impl Fn(&Method) -> bool) -> String {
        let names: Vec<String> = MeshAlgorithm::ALL
            .iter()
            .map(|a| a.method())
            .filter(|m| which(m))
            .map(|m| format!("\"{}\"", m.name))
            .collect();
        match names.split_last() {
            None => String::new(),
            Some((last, [])) => last.clone(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        }
    }
}

/// The Hermite data source of the settings.
fn hermite<'f, 'g, 's>(
    f: &'f Field<'g>,
    sharp: &SharpSettings,
    source: Option<&'s PointField<'s>>,
) -> Result<hermite::Hermite<'f, 'g, 's>, MeshError> {
    let source = match sharp.hermite {
        HermiteNormals::Trilinear => None,
        HermiteNormals::Source => Some(source.ok_or(MeshError::NoPointSource)?),
    };
    Ok(hermite::Hermite { f, source })
}

/// `extended-mc` from the settings.
fn emc<'f, 'g, 's>(
    f: &'f Field<'g>,
    sharp: &SharpSettings,
    source: Option<&'s PointField<'s>>,
) -> Result<emc::Emc<'f, 'g, 's>, MeshError> {
    Ok(emc::Emc {
        hermite: hermite(f, sharp, source)?,
        threshold: sharp.qef_threshold,
        clamp: sharp.qef_clamp,
        cos_feature: sharp.feature_angle_deg.to_radians().cos(),
    })
}

/// `dual-contouring-qef`'s vertex rule from the settings.
fn dc_qef<'f, 'g, 's>(
    f: &'f Field<'g>,
    sharp: &SharpSettings,
    source: Option<&'s PointField<'s>>,
) -> Result<dcqef::DcQef<'f, 'g, 's>, MeshError> {
    Ok(dcqef::DcQef {
        hermite: hermite(f, sharp, source)?,
        threshold: sharp.qef_threshold,
        clamp: sharp.qef_clamp,
    })
}

/// Settings that never change a method's answer.
fn never(_: &SharpSettings) -> Option<&'static str> {
    None
}

static MARCHING_CUBES: Method = Method {
    algo: MeshAlgorithm::MarchingCubes,
    name: "marching-cubes",
    padding: 0,
    quads: false,
    sharp: false,
    adaptive: false,
    lattice_edges: true,
    gpu: Some(GpuPasses::MarchingCubes),
    gpu_float64: false,
    gpu_off: never,
    not_in_slabs: never,
    not_streamed: None,
    reference: |f, _, _| mc::extract(f),
    slab: Some(|f, _| Ok(Box::new(move |c| mc::extract_slab(f, c)))),
};

static MC33: Method = Method {
    algo: MeshAlgorithm::Mc33,
    name: "mc33",
    padding: 0,
    quads: false,
    sharp: false,
    adaptive: false,
    lattice_edges: false,
    gpu: Some(GpuPasses::Mc33),
    gpu_float64: true,
    gpu_off: never,
    not_in_slabs: never,
    not_streamed: Some("mc33 (its added vertices follow every edge vertex)"),
    reference: |f, _, _| mc33::extract(f),
    slab: Some(|f, _| Ok(Box::new(move |c| mc33::extract_slab(f, c)))),
};

static SURFACE_NETS: Method = Method {
    algo: MeshAlgorithm::SurfaceNets,
    name: "surface-nets",
    padding: 0,
    quads: true,
    sharp: false,
    adaptive: false,
    lattice_edges: true,
    gpu: Some(GpuPasses::Dual),
    gpu_float64: false,
    gpu_off: never,
    not_in_slabs: never,
    not_streamed: None,
    reference: |f, x, _| dual::extract(f, dual::Boundary::Open, x.opts, None),
    // The threaded path's own surface nets (`nets`), the reference's mesh bit for bit.
    slab: Some(|f, x| {
        let opts = x.opts;
        Ok(Box::new(move |c| nets::extract_slab(f, opts, c)))
    }),
};

static DUAL_CONTOURING: Method = Method {
    algo: MeshAlgorithm::DualContouring,
    name: "dual-contouring",
    padding: 1,
    quads: true,
    sharp: false,
    adaptive: false,
    lattice_edges: true,
    gpu: Some(GpuPasses::Dual),
    gpu_float64: false,
    gpu_off: never,
    not_in_slabs: never,
    not_streamed: None,
    reference: |f, x, _| dual::extract(f, dual::Boundary::Closed, x.opts, None),
    slab: Some(|f, x| {
        let opts = x.opts;
        Ok(Box::new(move |c| dual::extract_slab(f, dual::Boundary::Closed, opts, None, c)))
    }),
};

static MARCHING_TETRAHEDRA: Method = Method {
    algo: MeshAlgorithm::MarchingTetrahedra,
    name: "marching-tetrahedra",
    padding: 0,
    quads: false,
    sharp: false,
    adaptive: false,
    lattice_edges: true,
    gpu: Some(GpuPasses::Tetrahedra),
    gpu_float64: false,
    gpu_off: never,
    not_in_slabs: never,
    not_streamed: None,
    reference: |f, _, _| mt::extract(f),
    slab: Some(|f, _| Ok(Box::new(move |c| mt::extract_slab(f, c)))),
};

static DUAL_CONTOURING_QEF: Method = Method {
    algo: MeshAlgorithm::DualContouringQef,
    name: "dual-contouring-qef",
    padding: 1,
    quads: true,
    sharp: true,
    adaptive: true,
    lattice_edges: false,
    gpu: Some(GpuPasses::Dual),
    gpu_float64: false,
    // The passes do uniform, trilinear Hermite data.
    gpu_off: |s| {
        (s.hermite != HermiteNormals::Trilinear || s.mesh_error.is_some())
            .then_some(" with hermite = \"source\" or mesh_error")
    },
    not_in_slabs: |s| {
        s.mesh_error
            .map(|_| "dual-contouring-qef with mesh_error (its octree spans the whole grid)")
    },
    not_streamed: None,
    reference: |f, x, budget| {
        let q = dc_qef(f, &x.sharp, x.source)?;
        match x.sharp.mesh_error {
            Some(eps) => octree::extract(&q, eps, budget),
            None => dual::extract(f, dual::Boundary::Closed, x.opts, Some(&q)),
        }
    },
    slab: Some(|f, x| {
        let (q, opts) = (dc_qef(f, &x.sharp, x.source)?, x.opts);
        Ok(Box::new(move |c| dual::extract_slab(f, dual::Boundary::Closed, opts, Some(&q), c)))
    }),
};

static EXTENDED_MC: Method = Method {
    algo: MeshAlgorithm::ExtendedMc,
    name: "extended-mc",
    padding: 0,
    quads: false,
    sharp: true,
    adaptive: false,
    lattice_edges: false,
    gpu: None,
    gpu_float64: false,
    gpu_off: never,
    not_in_slabs: |_| Some("extended-mc (its edge flips look at cells of any distance)"),
    not_streamed: None,
    reference: |f, x, budget| emc(f, &x.sharp, x.source)?.extract(budget),
    slab: None,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_algorithm_has_its_row() {
        let mut names = std::collections::BTreeSet::new();
        for a in MeshAlgorithm::ALL {
            assert_eq!(a.method().algo, a, "{a:?} points at another method's row");
            assert!(names.insert(a.name()), "{} is named twice", a.name());
            // The mc33 passes are the ones that need shaderFloat64 (`Mc33Passes::new`).
            let m = a.method();
            assert_eq!(m.gpu_float64, m.gpu == Some(GpuPasses::Mc33), "{a:?}");
            // A method never cut into slabs says why (`window::with_slab`).
            let d = SharpSettings::default();
            assert!(m.slab.is_some() || (m.not_in_slabs)(&d).is_some(), "{a:?}");
        }
        // The dual methods' padding is the boundary their reference and slabs use.
        for (a, b) in [
            (MeshAlgorithm::SurfaceNets, dual::Boundary::Open),
            (MeshAlgorithm::DualContouring, dual::Boundary::Closed),
            (MeshAlgorithm::DualContouringQef, dual::Boundary::Closed),
        ] {
            assert_eq!(a.method().padding, dual::padding(b), "{a:?}");
        }
    }

    #[test]
    fn the_cpu_instead_rule() {
        let d = SharpSettings::default();
        let source = SharpSettings { hermite: HermiteNormals::Source, ..d };
        let adaptive = SharpSettings { mesh_error: Some(0.1), ..d };
        let m = |a: MeshAlgorithm| a.method();
        for a in MeshAlgorithm::ALL {
            let gpu = !matches!(a, MeshAlgorithm::ExtendedMc);
            assert_eq!(m(a).cpu_instead(&d, true).is_none(), gpu, "{a:?}");
        }
        assert_eq!(m(MeshAlgorithm::Mc33).cpu_instead(&d, false), Some(CpuInstead::NoFloat64));
        assert_eq!(m(MeshAlgorithm::MarchingCubes).cpu_instead(&d, false), None);
        let qef = m(MeshAlgorithm::DualContouringQef);
        let off = Some(CpuInstead::NoPasses { with: " with hermite = \"source\" or mesh_error" });
        assert_eq!(qef.cpu_instead(&source, true), off);
        assert_eq!(qef.cpu_instead(&adaptive, true), off);
        assert_eq!(
            CpuInstead::NoPasses { with: "" }.note(m(MeshAlgorithm::ExtendedMc), "x"),
            "note: extended-mc is extracted on the CPU (no GPU extraction passes for it)"
        );
        assert_eq!(
            CpuInstead::NoFloat64.note(m(MeshAlgorithm::Mc33), "llvmpipe"),
            "note: mc33 is extracted on the CPU (llvmpipe has no 64-bit floats, which the GPU \
             mc33 passes need)"
        );
    }

    #[test]
    fn names_where_lists_the_methods_as_messages_do() {
        assert_eq!(Method::names_where(|m| m.adaptive), "\"dual-contouring-qef\"");
        assert_eq!(
            Method::names_where(|m| m.padding == 1),
            "\"dual-contouring\" or \"dual-contouring-qef\""
        );
        assert_eq!(
            Method::names_where(|m| m.gpu.is_none() || m.gpu_float64),
            "\"mc33\" or \"extended-mc\""
        );
        assert_eq!(
            Method::names_where(|m| m.quads),
            "\"surface-nets\", \"dual-contouring\" or \"dual-contouring-qef\""
        );
        assert_eq!(Method::names_where(|_| false), "");
    }
}
