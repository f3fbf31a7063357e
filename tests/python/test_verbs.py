"""Scene.from_toml / to_toml, and probe, slice, stats, compare: each the CLI verb's answer."""

import json

import numpy as np
import pytest

import isoview


def test_to_toml_writes_a_scene_that_loads_to_the_same_render(repo, tmp_path):
    scene = isoview.Scene.from_toml("scenes/volume-npy.toml",
                                    set=["image.width=24", "image.height=20",
                                         "render.shading=normal"])
    text = scene.to_toml()
    assert text.startswith("# Written by isoview.Scene.to_toml from scenes/volume-npy.toml with "
                           "--set image.width=24 --set image.height=20 --set render.shading=normal\n")
    copy = repo / "scenes" / f".pytest-copy-{tmp_path.name}.toml"  # relative data paths
    try:
        copy.write_text(text)
        again = isoview.Scene.from_toml(copy)
        assert (again.width, again.height) == (24, 20)
        a = isoview.render(scene, aovs=("rgba",)).rgba
        b = isoview.render(again, aovs=("rgba",)).rgba
        assert a.tobytes() == b.tobytes()
    finally:
        copy.unlink(missing_ok=True)


def test_probe_is_the_cli_probe_json(cli):
    p = cli("probe", "scenes/torus.toml", "--pixel", "128,130", "--json")
    assert isoview.probe("scenes/torus.toml", (128, 130)) == json.loads(p.stdout)
    with pytest.raises(ValueError) as e:
        isoview.probe("scenes/torus.toml", (256, 256))
    assert str(e.value) == "--pixel 256,256: outside the 256x256 image"


def test_slice_contours_are_the_cli_json(cli, tmp_path):
    cli("slice", "scenes/torus.toml", "-o", tmp_path / "s.exr", "--axis", "z", "--at", "0.1",
        "--json", tmp_path / "c.json")
    theirs = json.loads((tmp_path / "c.json").read_text())["contours"]
    mine = isoview.slice("scenes/torus.toml", "z", 0.1)
    assert len(mine) == len(theirs) == 2
    for points, closed, c in zip(mine, mine.closed, theirs):
        assert closed == c["closed"]
        assert points.shape == (len(c["points"]), 2)
        assert np.array_equal(points, np.array(c["points"])[:, :2])


def test_stats_are_the_cli_stats(cli):
    text = cli("stats", "scenes/torus.toml").stdout
    s = isoview.stats("scenes/torus.toml")
    line = {l.split()[0]: l.split(None, 1)[1] for l in text.splitlines() if l[:1].isalpha()}
    lo, hi = line["range"].split(" .. ")
    assert (s["min"], s["max"]) == (float(lo), float(hi))
    assert s["mean"] == float(line["mean"]) and s["sigma"] == float(line["sigma"])
    assert tuple(s["dims"]) == (48, 48, 48) and s["count"] == 48**3
    assert sum(s["histogram"]) == s["count"] and len(s["histogram"]) == 24
    a = np.arange(24, dtype=">i2").reshape(2, 3, 4)
    assert isoview.stats(a)["dtype"] == ">i2" and isoview.stats(a)["max"] == 23


def test_compare_is_the_cli_compare(cli, tmp_path):
    scene = isoview.Scene.from_toml("scenes/sphere.toml", set=["image.width=32",
                                                               "image.height=32"])
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    isoview.render(scene).save_exr(a)
    isoview.render(scene, method="fixed-step", render={"steps": 8}).save_exr(b)
    p = cli("compare", a, b, check=False)
    report = isoview.compare(a, b)
    assert (report.status, report.report) == (p.returncode, p.stdout)
    assert p.returncode == 1 and not report.passed
    assert isoview.compare(a, a).passed
    p = cli("compare", a, tmp_path / "nope.exr", check=False)
    with pytest.raises(ValueError) as e:
        isoview.compare(a, tmp_path / "nope.exr")
    assert p.returncode == 2 and p.stderr.strip() == f"isoview: {e.value}"
