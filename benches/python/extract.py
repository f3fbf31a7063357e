"""isoview.extract vs skimage.measure.marching_cubes vs PyMCubes on the same volumes, in one
run: the table of docs/python.md ("Timings"). Median of --repeat calls each, after one warm-up
call; every tool gets the same float32 array (PyMCubes: float64, which it takes).

    .venv/bin/python benches/python/extract.py [--sizes 64,128,192] [--repeat 5]
"""

import argparse
import os
import platform
import statistics
import time

import numpy as np


def volumes(n):
    x, y, z = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j].astype(np.float32)
    sphere = 1.0 - np.sqrt(x**2 + y**2 + z**2)                     # one smooth surface
    gyroid = (np.sin(6 * x) * np.cos(6 * y) + np.sin(6 * y) * np.cos(6 * z)
              + np.sin(6 * z) * np.cos(6 * x))                     # many triangles
    return {"sphere": (sphere, 0.4), "gyroid": (gyroid.astype(np.float32), 0.0)}


def timed(f, repeat):
    f()
    runs = []
    for _ in range(repeat):
        t = time.perf_counter()
        out = f()
        runs.append(time.perf_counter() - t)
    return statistics.median(runs) * 1e3, out


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--sizes", default="64,128,192")
    p.add_argument("--repeat", type=int, default=5)
    args = p.parse_args()
    import isoview
    import mcubes
    from skimage import measure

    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"isoview {isoview.__version__}, scikit-image "
          f"{__import__('skimage').__version__}, PyMCubes {getattr(mcubes, '__version__', '?')}")
    print("| volume | isoview.extract | skimage lorensen | skimage lewiner | PyMCubes | triangles |")
    print("| --- | --- | --- | --- | --- | --- |")
    for n in map(int, args.sizes.split(",")):
        for name, (v, level) in volumes(n).items():
            d = v.astype(np.float64)
            iso, (_, faces, _, _) = timed(lambda: isoview.extract(v, level), args.repeat)
            lor, (_, sf, _, _) = timed(
                lambda: measure.marching_cubes(v, level, method="lorensen"), args.repeat)
            lew, _ = timed(lambda: measure.marching_cubes(v, level), args.repeat)
            mc, _ = timed(lambda: mcubes.marching_cubes(d, level), args.repeat)
            assert len(faces) == len(sf), (name, n)
            print(f"| {name} {n}³ | {iso:.1f} ms | {lor:.1f} ms | {lew:.1f} ms | {mc:.1f} ms "
                  f"| {len(faces)} |")


if __name__ == "__main__":
    main()
