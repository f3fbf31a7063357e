"""Regenerates tests/data/skimage_mc_cassini16.txt: scikit-image's marching cubes on a 16^3 grid.

Run by hand (never by the tests): `python3 tests/data/skimage_mc.py` with numpy and scikit-image
installed. The field is a product of two squared distances (a Cassini-like surface), computed in
float64 in exactly the order the Rust test uses and rounded to float32, so both sides see the same
samples. The array is indexed vol[i, j, k] with i along x, so scikit-image's vertex coordinates
(array-index order) are (x, y, z) here; for a vol[z, y, x] array they would come out as (z, y, x).
"""

import os

import numpy as np
import skimage
from skimage.measure import marching_cubes

N = 16
C1 = (5.3, 7.1, 7.7)
C2 = (10.2, 8.4, 7.2)
LEVEL = 200.0


def field():
    vol = np.empty((N, N, N), dtype=np.float32)
    for i in range(N):
        for j in range(N):
            for k in range(N):
                x, y, z = float(i), float(j), float(k)
                d1 = (x - C1[0]) * (x - C1[0]) + (y - C1[1]) * (y - C1[1]) + (z - C1[2]) * (z - C1[2])
                d2 = (x - C2[0]) * (x - C2[0]) + (y - C2[1]) * (y - C2[1]) + (z - C2[2]) * (z - C2[2])
                vol[i, j, k] = np.float32(d1 * d2)
    return vol


def main():
    vol = field()
    out = {"skimage": skimage.__version__, "n": N, "c1": C1, "c2": C2, "level": LEVEL}
    out["value_sum"] = float(vol.astype(np.float64).sum())
    for method in ("lorensen", "lewiner"):
        verts, faces, _normals, _values = marching_cubes(vol, LEVEL, method=method, allow_degenerate=True)
        out[method] = {"vertices": int(len(verts)), "triangles": int(len(faces))}
    verts, faces, _, _ = marching_cubes(vol, LEVEL, method="lorensen", allow_degenerate=True)
    # Welded vertex set, sorted, rounded to 1e-4 (skimage computes in float32).
    pts = sorted({(round(float(v[0]), 4), round(float(v[1]), 4), round(float(v[2]), 4)) for v in verts})
    out["unique_vertices"] = pts
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "skimage_mc_cassini16.txt")
    with open(path, "w") as f:
        f.write("# scikit-image %s marching_cubes on tests/data/skimage_mc.py's field; do not edit\n" % out["skimage"])
        f.write("n %d\nlevel %r\nvalue_sum %r\n" % (N, LEVEL, out["value_sum"]))
        for method in ("lorensen", "lewiner"):
            f.write("%s %d %d\n" % (method, out[method]["vertices"], out[method]["triangles"]))
        for p in pts:
            f.write("v %r %r %r\n" % p)
    print(path, len(pts), out["lorensen"], out["lewiner"])


if __name__ == "__main__":
    main()
