"""extract(): scikit-image's `marching_cubes(method="lorensen")` conventions and mesh (the
same triangle count and vertex set) on random volumes, spacing, orientation, the named tuple."""

import numpy as np
import pytest
from skimage import measure

import isoview


def _rows(v):
    """The rows of `v` (float32, rounded to absorb the last bits of f32 interpolation), sorted."""
    r = np.round(np.asarray(v, dtype=np.float64), 4)
    return r[np.lexsort(r.T[::-1])]


@pytest.mark.parametrize("seed", range(6))
def test_lorensen_same_triangle_count_and_vertices_as_scikit_image(seed):
    rng = np.random.default_rng(seed)
    shape = tuple(rng.integers(4, 14, size=3))
    volume = rng.random(shape).astype(np.float32)
    level = float(rng.uniform(0.3, 0.7))
    spacing = tuple(float(s) for s in rng.uniform(0.5, 2.0, size=3))
    sv, sf, sn, _ = measure.marching_cubes(volume, level, spacing=spacing, method="lorensen")
    verts, faces, normals, values = isoview.extract(volume, level, spacing=spacing,
                                                    method="lorensen")
    assert len(faces) == len(sf)
    assert len(verts) == len(sv)
    assert np.abs(_rows(verts) - _rows(sv)).max() < 2e-4
    assert verts.dtype == np.float32 and faces.dtype == np.int32
    assert normals.dtype == np.float32 and values.dtype == np.float32
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    # scikit-image's `values`, vertex by vertex (each isoview vertex paired with the nearest
    # of scikit-image's).
    _, _, _, svalues = measure.marching_cubes(volume, level, spacing=spacing, method="lorensen")
    nearest = np.argmin(((verts[:, None, :] - sv[None, :, :]) ** 2).sum(axis=2), axis=1)
    assert np.allclose(values, svalues[nearest], rtol=0, atol=1e-6), "scikit-image's values"


def test_orientation_is_scikit_images_the_object_above_the_level():
    # A ball of high values: scikit-image's default ("descent") normals point out of it, and
    # so do isoview's; faces run counter-clockwise seen from outside (positive volume).
    x, y, z = np.mgrid[-1:1:20j, -1:1:20j, -1:1:20j]
    ball = (1.0 - np.sqrt(x**2 + y**2 + z**2)).astype(np.float32)
    verts, faces, normals, _ = isoview.extract(ball, 0.4)
    centre = verts.mean(axis=0)
    assert np.mean(np.sum((verts - centre) * normals, axis=1) > 0) > 0.99
    sv, sf, sn, _ = measure.marching_cubes(ball, 0.4, method="lorensen")
    assert np.mean(np.sum((sv - sv.mean(axis=0)) * sn, axis=1) > 0) > 0.99
    a, b, c = (verts[faces[:, i]].astype(np.float64) - centre for i in range(3))
    assert np.sum(np.einsum("ij,ij->i", a, np.cross(b, c))) > 0, "outward winding"
    # `inside="below"` turns it inside out.
    _, _, flipped, _ = isoview.extract(ball, 0.4, inside="below")
    assert np.allclose(flipped, -normals)


def test_level_none_is_the_middle_of_the_range_and_the_result_is_a_tuple():
    volume = np.random.default_rng(7).random((9, 8, 7))
    mesh = isoview.extract(volume)
    lo, hi = float(volume.astype(np.float32).min()), float(volume.astype(np.float32).max())
    at_middle = isoview.extract(volume, (lo + hi) / 2)
    assert np.array_equal(mesh.verts, at_middle.verts) and np.array_equal(mesh.faces, at_middle.faces)
    assert not np.array_equal(mesh.verts, isoview.extract(volume, (lo + hi) / 2 + 0.01).verts)
    verts, faces = mesh[:2]
    assert verts is mesh.verts and faces is mesh.faces
    assert isinstance(mesh, tuple) and len(mesh) == 4
    assert mesh.ran_on.startswith(("cpu", "gpu")) and mesh.surface.shape == (len(verts),)
    trimesh = pytest.importorskip("trimesh")
    t = mesh.to_trimesh()
    assert isinstance(t, trimesh.Trimesh) and len(t.faces) == len(faces)


def test_other_methods_and_origin():
    volume = np.random.default_rng(3).random((10, 10, 10), dtype=np.float32)
    for method in ("mc33", "lewiner", "surface-nets", "dual-contouring",
                   "marching-tetrahedra"):
        verts, faces, _, _ = isoview.extract(volume, 0.5, method=method)
        assert len(faces) > 0 and faces.max() < len(verts), method
    a = isoview.extract(volume, 0.5).verts
    b = isoview.extract(volume, 0.5, origin=(10, 20, 30)).verts
    assert np.allclose(b - a, [10, 20, 30], atol=1e-4)


def test_a_scene_extracts_as_the_cli_extract(cli, tmp_path):
    scene = isoview.Scene.from_toml("scenes/sphere.toml")
    mesh = isoview.extract(scene)
    ply = tmp_path / "s.ply"
    p = cli("extract", "scenes/sphere.toml", "-o", ply)
    # The CLI's summary line: "V vertices, T triangles (...)".
    words = p.stderr.split()
    assert (int(words[1]), int(words[3])) == (len(mesh.verts), len(mesh.faces))
    # The PLY's positions are the mesh's (binary little-endian float32 x, y, z first).
    data = ply.read_bytes()
    header_end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:header_end].decode()
    assert f"element vertex {len(mesh.verts)}" in header
    props = [l.split()[-1] for l in header.splitlines() if l.startswith("property") and
             "list" not in l and header.index(l) < header.index("element face")]
    stride = 4 * len(props)
    raw = np.frombuffer(data[header_end:header_end + stride * len(mesh.verts)], dtype="<f4")
    ply_verts = raw.reshape(len(mesh.verts), len(props))[:, :3]
    assert ply_verts.tobytes() == mesh.verts.tobytes()


def test_gpu_extraction_runs_on_the_process_device_and_agrees_with_the_cpu():
    volume = np.random.default_rng(11).random((12, 11, 10), dtype=np.float32)
    isoview.render(volume, 0.5, width=4, height=4)          # the device is opened once here
    cpu = isoview.extract(volume, 0.5, device="cpu")
    gpu = isoview.extract(volume, 0.5, device="gpu")
    assert cpu.ran_on.startswith("cpu") and gpu.ran_on.startswith("gpu")
    assert len(gpu.faces) == len(cpu.faces) and len(gpu.verts) == len(cpu.verts)
    assert np.abs(_rows(gpu.verts) - _rows(cpu.verts)).max() < 2e-4
    with pytest.raises(ValueError, match='^device "tpu": expected "auto", "cpu" or "gpu"$'):
        isoview.extract(volume, 0.5, device="tpu")
