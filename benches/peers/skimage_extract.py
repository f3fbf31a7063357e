"""What a Python user would run instead of `isoview extract`: load, marching cubes, write PLY.

    python skimage_extract.py FIELD.npy OUT.ply LO HI

Timed as a whole process by peers.py, exactly as `isoview extract` is, imports included.
LO and HI are the box's corners on every axis (cubic boxes here), so the mesh lands in the
same world coordinates as isoview's. Prints "VERTICES TRIANGLES".
"""

import sys

import numpy as np
import trimesh
from skimage.measure import marching_cubes

path, out, lo, hi = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
vol = np.load(path)  # vol[i, j, k] is the point (x_i, y_j, z_k), as isoview reads it
spacing = tuple((hi - lo) / (n - 1) for n in vol.shape)
verts, faces, normals, _ = marching_cubes(vol, level=0.0, spacing=spacing)
# process=False: keep skimage's vertices as they are (no merging), so the counts are its own.
mesh = trimesh.Trimesh(verts + lo, faces, vertex_normals=normals, process=False)
mesh.export(out)
print(len(verts), len(faces))
