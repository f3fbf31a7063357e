//! Writing meshes: binary PLY (positions, normals, faces), Wavefront OBJ (`v`, `vn`, `f v//vn`)
//! and binary STL (facet normals from the triangles' geometry).
//!
//! Writers take any [`std::io::Write`] and buffer internally; making the file appear whole or not
//! at all (write a temporary, then rename) is the caller's job. PLY and OBJ write the quads of
//! [`Mesh::quads`] when present, triangles otherwise; STL holds triangles only.

use std::io::{self, BufWriter, Write};
use std::path::Path;

use glam::Vec3;

use super::Mesh;

/// A mesh file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Ply,
    Obj,
    Stl,
}

impl Format {
    /// The format named by a path's extension (`.ply`, `.obj`, `.stl`, any case).
    pub fn from_path(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "ply" => Some(Format::Ply),
            "obj" => Some(Format::Obj),
            "stl" => Some(Format::Stl),
            _ => None,
        }
    }
}

/// Writes `mesh` to `w` in `format`.
pub fn write<W: Write>(mesh: &Mesh, format: Format, w: W) -> io::Result<()> {
    write_labelled(mesh, None, format, w)
}

/// [`write`], with each vertex's surface (`mesh::merge`) where there are several: PLY gives
/// the vertex a `uchar surface` property; OBJ and STL have no per-vertex labels (OBJ and STL
/// readers would drop them) and are written as [`write`] does.
pub fn write_labelled<W: Write>(
    mesh: &Mesh,
    labels: Option<&[u32]>,
    format: Format,
    w: W,
) -> io::Result<()> {
    match format {
        Format::Ply => write_ply_labelled(mesh, labels, w),
        Format::Obj => write_obj(mesh, w),
        Format::Stl => write_stl(mesh, w),
    }
}

/// The faces to write: quads if the mesh has them, else triangles.
fn faces(mesh: &Mesh) -> (&[u32], usize) {
    match &mesh.quads {
        Some(q) => (q.as_slice(), 4),
        None => (mesh.indices.as_slice(), 3),
    }
}

/// Binary little-endian PLY: `vertex` with float `x y z nx ny nz`, `face` with
/// `list uchar uint vertex_indices`.
pub fn write_ply<W: Write>(mesh: &Mesh, w: W) -> io::Result<()> {
    write_ply_labelled(mesh, None, w)
}

/// [`write_ply`], plus `property uchar surface` after the normal when `labels` are given.
pub fn write_ply_labelled<W: Write>(mesh: &Mesh, labels: Option<&[u32]>, w: W) -> io::Result<()> {
    let mut w = BufWriter::new(w);
    let (faces, n) = faces(mesh);
    ply_header(&mut w, mesh.positions.len(), faces.len() / n, labels.is_some())?;
    ply_vertices(&mut w, mesh, labels)?;
    ply_faces(&mut w, faces, n)?;
    w.flush()
}

/// The header of [`write_ply_labelled`]'s file of `vertices` vertices and `faces` faces.
fn ply_header(w: &mut impl Write, vertices: usize, faces: usize, labelled: bool) -> io::Result<()> {
    let label_property = if labelled { "property uchar surface\n" } else { "" };
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment isoview {}\n\
         element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n{label_property}\
         element face {faces}\nproperty list uchar uint vertex_indices\nend_header\n",
        crate::VERSION,
    )
}

/// Records are encoded into a block of BLOCK of them and the block written whole: a write_all
/// per number (4 bytes each) into the BufWriter cost more than the encoding.
const BLOCK: usize = 1 << 14;

/// The vertex records of `mesh`: position and normal as f32, then the label as a `uchar`.
fn ply_vertices(w: &mut impl Write, mesh: &Mesh, labels: Option<&[u32]>) -> io::Result<()> {
    let mut block = Vec::new();
    let nv = mesh.positions.len();
    for start in (0..nv).step_by(BLOCK) {
        block.clear();
        for i in start..(start + BLOCK).min(nv) {
            for c in mesh.positions[i].iter().chain(&mesh.normals[i]) {
                block.extend_from_slice(&c.to_le_bytes());
            }
            if let Some(l) = labels {
                block.push(l[i] as u8);
            }
        }
        w.write_all(&block)?;
    }
    Ok(())
}

/// The face records of `faces`, `n` vertex indices each: the count as a `uchar`, the indices
/// as `uint`.
fn ply_faces(w: &mut impl Write, faces: &[u32], n: usize) -> io::Result<()> {
    let mut block = Vec::new();
    for chunk in faces.chunks(BLOCK * n) {
        block.clear();
        for f in chunk.chunks_exact(n) {
            block.push(n as u8);
            for v in f {
                block.extend_from_slice(&v.to_le_bytes());
            }
        }
        w.write_all(&block)?;
    }
    Ok(())
}

/// A binary PLY written piece by piece (the pieces of `mesh::extract_streamed`, in order): the
/// vertex records and the face records go to two scratch files as the pieces come, and
/// [`PlyPieces::finish`] writes the header with the exact counts, then the vertex records,
/// then the face records: [`write_ply`]'s file of the pieces joined, byte for byte, with
/// only a piece in memory at a time.
pub struct PlyPieces<V: Write, F: Write> {
    vertices: BufWriter<V>,
    faces: BufWriter<F>,
    /// Vertices, faces and triangles so far.
    counts: (usize, usize, usize),
}

impl<V: Write, F: Write> PlyPieces<V, F> {
    /// Records go to `vertices` and `faces` (scratch files, read back by [`PlyPieces::finish`]).
    pub fn new(vertices: V, faces: F) -> Self {
        PlyPieces {
            vertices: BufWriter::new(vertices),
            faces: BufWriter::new(faces),
            counts: (0, 0, 0),
        }
    }

    /// Appends the next piece: vertices numbered after those of the pieces before it, faces
    /// numbered in the whole mesh (its quads when it has them, as [`write_ply`] writes).
    pub fn push(&mut self, piece: &Mesh) -> io::Result<()> {
        let (faces, n) = faces(piece);
        ply_vertices(&mut self.vertices, piece, None)?;
        ply_faces(&mut self.faces, faces, n)?;
        let (v, f, t) = self.counts;
        self.counts = (v + piece.vertex_count(), f + faces.len() / n, t + piece.triangle_count());
        Ok(())
    }

    /// Vertices, faces and triangles pushed so far.
    pub fn counts(&self) -> (usize, usize, usize) {
        self.counts
    }

    /// Writes the file to `out`: the header, then the records read back from `vertices` and
    /// `faces`, readers of the scratch files from their starts (the writers are flushed and
    /// closed first).
    pub fn finish(
        self,
        out: &mut impl Write,
        mut vertices: impl io::Read,
        mut faces: impl io::Read,
    ) -> io::Result<()> {
        self.vertices.into_inner().map_err(io::IntoInnerError::into_error)?;
        self.faces.into_inner().map_err(io::IntoInnerError::into_error)?;
        ply_header(out, self.counts.0, self.counts.1, false)?;
        io::copy(&mut vertices, out)?;
        io::copy(&mut faces, out)?;
        Ok(())
    }
}

/// Wavefront OBJ: `v x y z`, `vn nx ny nz` (vertex `i` uses normal `i`), `f a//a b//b c//c`
/// (1-based). Numbers are written in the shortest form that reads back to the same f32.
pub fn write_obj<W: Write>(mesh: &Mesh, w: W) -> io::Result<()> {
    let mut w = BufWriter::new(w);
    let (faces, n) = faces(mesh);
    writeln!(w, "# isoview {}", crate::VERSION)?;
    writeln!(w, "# {} vertices, {} faces", mesh.positions.len(), faces.len() / n)?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p[0], p[1], p[2])?;
    }
    for q in &mesh.normals {
        writeln!(w, "vn {} {} {}", q[0], q[1], q[2])?;
    }
    for f in faces.chunks_exact(n) {
        write!(w, "f")?;
        for v in f {
            write!(w, " {0}//{0}", v + 1)?;
        }
        writeln!(w)?;
    }
    w.flush()
}

/// Binary STL: an 80-byte header (not starting with `solid`), the triangle count, and per
/// triangle its unit geometric normal (zero for a degenerate one), three vertices and a zero
/// attribute word.
pub fn write_stl<W: Write>(mesh: &Mesh, w: W) -> io::Result<()> {
    let mut w = BufWriter::new(w);
    let mut header = [b' '; 80];
    let text = format!("isoview {} binary STL", crate::VERSION);
    let len = text.len().min(80);
    header[..len].copy_from_slice(&text.as_bytes()[..len]);
    w.write_all(&header)?;
    let count = u32::try_from(mesh.triangle_count())
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "too many triangles for STL"))?;
    w.write_all(&count.to_le_bytes())?;
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(t).map(|v| Vec3::from(mesh.positions[v as usize]));
        let n = (b - a).cross(c - a).normalize_or_zero();
        for v in [n, a, b, c] {
            for x in v.to_array() {
                w.write_all(&x.to_le_bytes())?;
            }
        }
        w.write_all(&[0, 0])?;
    }
    w.flush()
}
