"""render(): the CLI's render of the same scene bit for bit (the EXR's bytes, and every
channel through `isoview compare --fail 0`), arrays the same as their .npy file, the image's
arrays and PNG, and the GIL released while it renders."""

import threading

import numpy as np
import pytest

import isoview

SMALL = ["image.width=48", "image.height=40"]

# Scenes of every ray method and field source kind the CLI's examples use.
SCENES = [
    ("scenes/torus.toml", []),
    ("scenes/sphere.toml", ["render.method=fixed-step", "render.steps=64"]),
    ("scenes/volume-npy.toml", ["render.shading=normal"]),
    ("scenes/nrrd-ellipsoid.toml", []),
    ("scenes/gyroid-clipped.toml", ["field.interpolation=catmull-rom"]),
]


@pytest.mark.parametrize("path,sets", SCENES)
def test_scene_render_is_the_cli_exr_byte_for_byte(cli, tmp_path, path, sets):
    sets = SMALL + sets
    cli_exr = tmp_path / "cli.exr"
    args = ["render", path, "-o", cli_exr]
    for s in sets:
        args += ["--set", s]
    cli(*args)
    scene = isoview.Scene.from_toml(path, set=sets)
    image = isoview.render(scene)
    py_exr = tmp_path / "py.exr"
    image.save_exr(py_exr)
    assert py_exr.read_bytes() == cli_exr.read_bytes()
    # Channel by channel, through the CLI's own comparison with no tolerance.
    report = isoview.compare(cli_exr, py_exr, fail=0, no_flip=True)
    assert report.passed, report.report
    # Every channel the CLI writes is in the image.
    assert image.channels == tuple(scene.channels)
    assert "R" in image.channels and "cell.Z" in image.channels


def test_keyword_arguments_are_the_cli_set_overrides(cli, tmp_path):
    cli_exr = tmp_path / "cli.exr"
    cli("render", "scenes/torus.toml", "-o", cli_exr, "--set", "image.width=40", "--set",
        "image.height=30", "--set", "render.method=fixed-step", "--set", "render.shading=normal",
        "--set", "camera.fov_y_deg=30")
    scene = isoview.Scene.from_toml("scenes/torus.toml")
    image = isoview.render(scene, width=40, height=30, method="fixed-step",
                           camera={"fov_y_deg": 30}, render={"shading": "normal"})
    py_exr = tmp_path / "py.exr"
    image.save_exr(py_exr)
    assert py_exr.read_bytes() == cli_exr.read_bytes()
    # Unset keywords keep the scene's values.
    assert isoview.render(scene, width=8, height=6).summary["method"] == "analytic"


def _same(a, b):
    """Bit for bit, NaN included."""
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def test_an_array_renders_as_its_npy_file_does(repo, cli, tmp_path):
    blobs = np.load(repo / "scenes/data/blobs.npy")
    scene = isoview.Scene.from_toml("scenes/volume-npy.toml", set=SMALL)
    from_file = isoview.render(scene, aovs=("rgba", "depth", "normal", "position", "cell"))
    from_array = isoview.render(blobs, 100.0, spacing=[2 / 31] * 3, origin=(-1, -1, -1),
                                camera={"eye": [1.9, 1.2, 2.1], "target": [0, 0, 0],
                                        "fov_y_deg": 40.0},
                                width=48, height=40,
                                aovs=("rgba", "depth", "normal", "position", "cell"))
    for name in from_file.aovs:
        assert _same(from_array.aovs[name], from_file.aovs[name]), name
    # Through the CLI: every channel equal (the headers differ only in the scene's name).
    a, b = tmp_path / "array.exr", tmp_path / "cli.exr"
    from_array.save_exr(a)
    cli("render", "scenes/volume-npy.toml", "-o", b, *sum((["--set", s] for s in SMALL), []))
    assert isoview.compare(b, a, fail=0, no_flip=True).passed
    # A data file's path renders as the array does.
    path = isoview.render(repo / "scenes/data/blobs.npy", 100.0, width=48, height=40)
    array = isoview.render(blobs, 100.0, width=48, height=40)
    assert _same(path.rgba, array.rgba)


def test_image_arrays_png_and_aovs():
    x, y, z = np.mgrid[-1:1:24j, -1:1:24j, -1:1:24j]
    volume = np.sqrt(x**2 + y**2 + z**2)
    image = isoview.render(volume, 0.6, inside="below", width=32, height=24,
                           aovs=("rgba", "depth", "normal", "steps"))
    assert image.rgba.shape == (24, 32, 4) and image.rgba.dtype == np.float32
    assert image.depth.shape == (24, 32) and image.normal.shape == (24, 32, 3)
    hit = np.isfinite(image.depth)
    assert hit[12, 16] and not hit[0, 0], "the fitted camera sees the sphere in the middle"
    assert np.all(image.rgba[..., 3][hit] == 1.0)
    n = np.linalg.norm(image.normal[hit], axis=-1)
    assert np.allclose(n, 1.0, atol=1e-5)
    assert _same(image["N.X"], image.normal[..., 0])
    png = image._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and png == image.png()
    with pytest.raises(AttributeError, match="was not asked for"):
        image.position
    with pytest.raises(ValueError, match="aov 'crossings': this render writes no crossings"):
        isoview.render(volume, 0.6, width=8, height=8, aovs=("crossings",))


def test_the_gil_is_released_while_it_renders():
    volume = np.random.default_rng(1).random((40, 40, 40), dtype=np.float32)
    ticks = []
    done = threading.Event()

    def work():
        isoview.render(volume, 0.5, width=160, height=160, method="fixed-step",
                       render={"steps": 400})
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        ticks.append(1)  # runs only while the render thread does not hold the GIL
        done.wait(0.001)
    t.join()
    assert len(ticks) > 5, f"the main thread ran {len(ticks)} times during the render"


def test_one_device_per_process():
    volume = np.zeros((2, 2, 2), dtype=np.float32)
    a = isoview.render(volume, 0.5, width=4, height=4).summary["device"]
    b = isoview.render(volume, 0.5, width=4, height=4).summary["device"]
    assert a == b
