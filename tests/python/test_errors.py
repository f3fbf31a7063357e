"""Bad input raises ValueError with the CLI's one-line message (and what scikit-image refuses
with ValueError); no Vulkan device raises NoDeviceError naming what to install."""

import os
import subprocess
import sys

import numpy as np
import pytest

import isoview


def _one_line(e):
    text = str(e.value)
    assert "\n" not in text and text
    return text


@pytest.mark.parametrize("shape,message", [
    ((4, 5), "the array: expected a 3-D array of shape (nx, ny, nz), got shape (4, 5)"),
    ((2, 2, 2, 2), "the array: expected a 3-D array of shape (nx, ny, nz), got shape (2, 2, 2, 2)"),
    ((3, 1, 3), "the array: every axis needs at least 2 points, got shape (3, 1, 3)"),
])
def test_what_scikit_image_refuses_is_refused(shape, message):
    for call in (lambda a: isoview.extract(a, 0.5), lambda a: isoview.render(a, 0.5)):
        with pytest.raises(ValueError) as e:
            call(np.zeros(shape, dtype=np.float32))
        assert _one_line(e) == message


def test_spacing_must_be_three_positive_numbers():
    a = np.zeros((3, 3, 3))
    with pytest.raises(ValueError) as e:
        isoview.extract(a, 0.5, spacing=(1, 1))
    assert _one_line(e) == "spacing: expected 3 numbers (x, y, z), one per axis, got 2"
    with pytest.raises(ValueError, match=r"^spacing: must be positive, got \[1.0, 0.0, 1.0\]$"):
        isoview.extract(a, 0.5, spacing=(1, 0, 1))


@pytest.mark.parametrize("call,message", [
    (lambda a: isoview.extract(a, 0.5, spacing="abc"),
     "spacing: expected 3 numbers (x, y, z), got 'abc'"),
    (lambda a: isoview.extract(a, 0.5, origin=(0, "x", 0)),
     "origin: expected 3 numbers (x, y, z), got (0, 'x', 0)"),
    (lambda a: isoview.extract(a, "half"), "level: expected a number, got 'half'"),
    (lambda a: isoview.render(a, [0.5]), "isovalue: expected a number, got [0.5]"),
    (lambda a: isoview.render(a, 0.5, time="now"), "time: expected a number, got 'now'"),
    (lambda a: isoview.slice(a, "z", at="mid"), "at: expected a number, got 'mid'"),
    (lambda a: isoview.stats(a, bins=2.5), "bins: expected a whole number, got 2.5"),
])
def test_a_keyword_of_the_wrong_type_is_a_value_error_naming_it(call, message):
    # Python's own conversions name neither the keyword nor the value ("could not convert
    # string to float: 'a'" for spacing="abc", a TypeError for a list).
    with pytest.raises(ValueError) as e:
        call(np.zeros((3, 3, 3), dtype=np.float32))
    assert _one_line(e) == message


def test_scene_errors_are_the_cli_line(cli, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[field]\nsource = "sdf"\nshape = "sphere"\nradius = 0.5\nresolution = [8, 8, 8]\n'
                   '[render]\nstepz = 3\n')
    p = cli("render", bad, "-o", tmp_path / "o.exr", check=False)
    assert p.returncode == 2
    with pytest.raises(ValueError) as e:
        isoview.Scene.from_toml(bad)
    assert p.stderr.strip() == f"isoview: {_one_line(e)}"
    # A --set as the CLI's.
    p = cli("render", "scenes/torus.toml", "-o", tmp_path / "o.exr", "--set", "render.steps=abc",
            check=False)
    with pytest.raises(ValueError) as e:
        isoview.render(isoview.Scene.from_toml("scenes/torus.toml"), set=["render.steps=abc"])
    assert p.stderr.strip() == f"isoview: {_one_line(e)}"

    # A scene naming a 2 MB path: the CLI's line, cut in the middle past 16K characters.
    far = tmp_path / "far.toml"
    far.write_text('[field]\nsource = "npy"\npath = "' + "a/" * 1_000_000 + 'x.npy"\n')
    p = cli("render", far, "-o", tmp_path / "o.exr", check=False)
    assert p.returncode == 2
    with pytest.raises(ValueError) as e:
        isoview.Scene.from_toml(far)
    line = _one_line(e)
    assert p.stderr.strip() == f"isoview: {line}"
    assert "characters cut) … a/a/" in line and line.endswith("cannot read: File name too long (os error 36)")
    assert len(line) < 17_000


def test_keyword_errors_name_the_scene_key():
    a = np.zeros((3, 3, 3))
    with pytest.raises(ValueError) as e:
        isoview.render(a, 0.5, width=0)
    assert _one_line(e) == "image.width: must be at least 1, got 0"
    with pytest.raises(ValueError) as e:
        isoview.render(a, 0.5, method="raytrace")
    assert _one_line(e).startswith('render.method: ')
    with pytest.raises(ValueError) as e:
        isoview.render(a, 0.5, render={"stepz": 3})
    assert "render.stepz" in _one_line(e)
    with pytest.raises(ValueError) as e:
        isoview.render(a, 0.5, interpolation="device")  # analytic does not read it
    assert _one_line(e).startswith('field.interpolation = "device": ')


def test_no_device_raises_no_device_error_naming_what_to_install():
    code = ("import numpy as np, isoview\n"
            "try:\n"
            "    isoview.render(np.zeros((2, 2, 2)), 0.5, width=4, height=4)\n"
            "except isoview.NoDeviceError as e:\n"
            "    print('NoDeviceError:', e)\n")
    for env in ({"ISOVIEW_DEVICE": "no-such-gpu"}, {"VK_ICD_FILENAMES": "/nonexistent.json"}):
        p = subprocess.run([sys.executable, "-c", code], env={**os.environ, **env},
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 0, p.stderr
        assert p.stdout.startswith("NoDeviceError: "), p.stdout + p.stderr
    assert issubclass(isoview.NoDeviceError, isoview.GpuError)
    assert issubclass(isoview.GpuError, RuntimeError)


def test_a_broadcast_view_over_the_cap_is_refused_before_any_copy():
    # np.broadcast_to makes an array of 800^3 samples (1953 MiB as float32) out of one: the
    # cap's line must come before the view is copied into one block (the attack pass saw 2 GB
    # of RSS first, and a MemoryError rather than ValueError at 2000^3). Run in a child so its
    # peak RSS is its own.
    import subprocess
    import sys
    code = """
import resource, numpy as np, isoview
for fn in (isoview.extract, isoview.render, isoview.stats):
    try:
        fn(np.broadcast_to(np.float32(1), (800, 800, 800)))
    except ValueError as e:
        assert "over the cap" in str(e), e
    else:
        raise SystemExit("no ValueError")
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    peak_kib = int(out.stdout.split()[-1])
    assert peak_kib < 600 * 1024, f"peak {peak_kib} KiB: the view was copied"


def test_a_probe_pixel_that_is_not_two_whole_numbers_is_a_value_error():
    volume = np.random.default_rng(3).random((6, 6, 6)).astype(np.float32)
    for pixel in [(-1, 0), (0, float("nan")), "ab", (1, 2, 3), (2**40, 0)]:
        with pytest.raises(ValueError) as e:
            isoview.probe(volume, pixel, 0.5, width=8, height=8)
        assert "pixel" in _one_line(e)
