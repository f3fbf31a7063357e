#!/usr/bin/python3
"""Writes the .vdb and .nvdb test files of tests/it/field/vdb.rs and their reference values.

Run with Debian 12's own python3 (python3-openvdb, python3-numpy) and vdb_tool
(libopenvdb-tools) installed:  /usr/bin/python3 tests/data/vdb/make.py

Every file is written by OpenVDB itself (pyopenvdb or vdb_tool); the reference is what
pyopenvdb reads back from the .vdb file: the active-voxel bounding box, the transform's image
of its first voxel and of one step along each index axis, and every value of the box
(copyToArray, i.e. the tree's getValue: active and inactive values, tiles, background) as
little-endian f32, x fastest, in NAME.f32. A .nvdb file made from a .vdb by vdb_tool has the
reference of the .vdb it came from. reference.json lists each file with its grid, its
reference and what isoview must say (a refusal's words) where it refuses one.
"""

import json
import math
import os
import subprocess

import numpy as np
import pyopenvdb as vdb

HERE = os.path.dirname(os.path.abspath(__file__))
os.chdir(HERE)
REF = {}


def reference(path, grid_name, ref_name):
    """pyopenvdb's reading of one grid of a .vdb file, saved as ref_name.f32."""
    g = vdb.read(path, grid_name)
    lo, hi = g.evalActiveVoxelBoundingBox()
    dims = [hi[k] - lo[k] + 1 for k in range(3)]
    a = np.zeros((dims[0], dims[1], dims[2]), dtype=np.float32)
    g.copyToArray(a, ijk=lo)
    # a[i, j, k]: x slowest; isoview's order is x fastest.
    a.transpose(2, 1, 0).astype("<f4").tofile(ref_name + ".f32")
    xf = g.transform
    o = xf.indexToWorld(lo)
    steps = []
    for k in range(3):
        p = list(lo)
        p[k] += 1
        w = xf.indexToWorld(tuple(p))
        steps.append([w[i] - o[i] for i in range(3)])
    return {
        "grid": g.name,
        "class": str(g.gridClass),
        "min_index": list(lo),
        "dims": dims,
        "origin": list(o),
        "steps": steps,
        "background": g.background,
        "values": ref_name + ".f32",
    }


def add(name, **entry):
    REF[name] = entry


def vdb_tool(*args):
    subprocess.run(["vdb_tool", "-quiet", *args], check=True)


# A level-set sphere: radius 5, centre (1, 2, 3), voxel size 0.5, half width 3 voxels.
s = vdb.createLevelSetSphere(radius=5.0, center=(1.0, 2.0, 3.0), voxelSize=0.5, halfWidth=3.0)
s.name = "sphere"
vdb.write("sphere.vdb", grids=[s])
add("sphere.vdb", **reference("sphere.vdb", "sphere", "sphere"))

# A sphere of radius 16 voxels, half width 2: its interior beyond the band is tiles of
# -background in the lower internal nodes (and +background tiles outside), as .vdb and .nvdb.
t = vdb.createLevelSetSphere(radius=8.0, center=(0.0, 0.0, 0.0), voxelSize=0.5, halfWidth=2.0)
t.name = "tiled"
assert any(it.depth == 2 and it.value < 0 for it in t.citerOffValues() if it.count > 1)
vdb.write("sphere_tiles.vdb", grids=[t])
add("sphere_tiles.vdb", **reference("sphere_tiles.vdb", "tiled", "sphere_tiles"))
vdb_tool("-read", "sphere_tiles.vdb", "-write", "codec=zip", "sphere_tiles.nvdb")
add("sphere_tiles.nvdb", **REF["sphere_tiles.vdb"])

# The same sphere saved as half floats.
h = s.deepCopy()
h.saveFloatAsHalf = True
vdb.write("sphere_half.vdb", grids=[h])
add("sphere_half.vdb", **reference("sphere_half.vdb", "sphere", "sphere_half"))

# A torus mesh (OBJ) turned into a level set by vdb_tool, written as .vdb (blosc) and .nvdb
# (zip codec; blosc and 16-bit quantization to be refused).
R, r, nu, nv = 6.0, 2.0, 48, 24
with open("torus.obj", "w") as f:
    for i in range(nu):
        for j in range(nv):
            u, v = 2 * math.pi * i / nu, 2 * math.pi * j / nv
            f.write("v %.6f %.6f %.6f\n" % ((R + r * math.cos(v)) * math.cos(u),
                                             (R + r * math.cos(v)) * math.sin(u), r * math.sin(v)))
    for i in range(nu):
        for j in range(nv):
            a = i * nv + j + 1
            b = ((i + 1) % nu) * nv + j + 1
            c = ((i + 1) % nu) * nv + (j + 1) % nv + 1
            d = i * nv + (j + 1) % nv + 1
            f.write("f %d %d %d\nf %d %d %d\n" % (a, b, c, a, c, d))
vdb_tool("-read", "torus.obj", "-mesh2ls", "d=40", "w=3", "-write", "torus.vdb")
os.remove("torus.obj")
torus = vdb.readAllGridMetadata("torus.vdb")[0].name
add("torus.vdb", **reference("torus.vdb", torus, "torus"))
vdb_tool("-read", "torus.vdb", "-write", "codec=zip", "torus_zip.nvdb")
add("torus_zip.nvdb", **REF["torus.vdb"])
vdb_tool("-read", "torus.vdb", "-write", "codec=blosc", "torus_blosc.nvdb")
add("torus_blosc.nvdb", refused="BLOSC-compressed NanoVDB")
vdb_tool("-read", "torus.vdb", "-write", "bits=16", "codec=zip", "torus_fp16.nvdb")
add("torus_fp16.nvdb", refused="(fp16)")
vdb_tool("-read", "sphere.vdb", "-write", "codec=zip", "sphere.nvdb")
add("sphere.nvdb", **REF["sphere.vdb"])

# Two small spheres far apart: a 155 x 145 x 135 box (12 MB densified) over a tree of one
# upper node, two lower nodes and their leaves (0.2 MB): the sparse paths' test
# (field::vdb::a_sparse_grid_over_the_cap_renders_and_extracts_as_its_dense_box). No reference
# values: the test compares with the box densified.
vdb_tool("-sphere", "voxel=1", "radius=4", "center=8,8,8", "-sphere", "voxel=1", "radius=4",
         "center=150,140,130", "-union", "-write", "two.vdb")
vdb_tool("-read", "two.vdb", "-write", "codec=zip", "two_zip.nvdb")
# Two spheres of radius 12 at opposite corners of a 715 x 705 x 695 box: dense brick tables
# would take 8 MiB, the hierarchical ones (superbricks and the blocks near the spheres) 0.1 MiB
# (field::vdb::hierarchical_tables_render_a_box_whose_dense_tables_are_over_the_cap).
vdb_tool("-sphere", "voxel=1", "radius=12", "center=14,14,14", "-sphere", "voxel=1",
         "radius=12", "center=700,690,680", "-union", "-write", "far.vdb")
vdb_tool("-read", "far.vdb", "-write", "codec=zip", "far_zip.nvdb")

# A dense array copied in (every voxel active: tolerance -1) with an affine transform: a
# rotation about z by 30 degrees, voxel sizes 0.5, 0.25, 2 per axis, a translation.
n = (7, 6, 5)
a = np.fromfunction(lambda i, j, k: np.sin(0.7 * i) + np.cos(0.5 * j) * (k - 2.0) + 0.1 * i * j,
                    n, dtype=np.float64).astype(np.float32)
d = vdb.FloatGrid(background=-100.0)
d.copyFromArray(a, ijk=(3, 2, 5), tolerance=-1.0)
c, sn = math.cos(math.radians(30)), math.sin(math.radians(30))
scale = (0.5, 0.25, 2.0)
rows = [[c * scale[0], sn * scale[0], 0, 0], [-sn * scale[1], c * scale[1], 0, 0],
        [0, 0, scale[2], 0], [10.0, -4.0, 1.5, 1]]
d.transform = vdb.createLinearTransform(rows)
d.name = "dense"
vdb.write("dense.vdb", grids=[d])
add("dense.vdb", **reference("dense.vdb", "dense", "dense"))
# Uncompressed NanoVDB (one upper node: the box lies in the positive index octant).
vdb_tool("-read", "dense.vdb", "-write", "codec=none", "dense.nvdb")
add("dense.nvdb", **REF["dense.vdb"])

# A sheared transform: refused (unless bounds).
sh = d.deepCopy()
sh.transform = vdb.createLinearTransform([[1, 0, 0, 0], [0.5, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
vdb.write("sheared.vdb", grids=[sh])
add("sheared.vdb", refused="sheared")

# A frustum transform: not linear, refused (unless bounds).
fr = d.deepCopy()
fr.transform = vdb.createFrustumTransform(xyzMin=(0, 0, 0), xyzMax=(10, 10, 10), taper=0.5,
                                          depth=5.0, voxelSize=1.0)
vdb.write("frustum.vdb", grids=[fr])
add("frustum.vdb", refused="not a linear map")

# What pyopenvdb cannot write (make_extra.cpp, OpenVDB's C++ API): ZIP .vdb files (OpenVDB 10
# writes BLOSC by default: every other .vdb here is BLOSC; it leaves ZIP out for level sets,
# so torus_zip.vdb has the active-mask compression only, dense_zip.vdb is ZIP), a double grid.
subprocess.run(["g++", "-std=c++17", "-O1", "-o", "/tmp/isoview_make_extra", "make_extra.cpp",
                "-lopenvdb", "-ltbb", "-lImath"], check=True)
subprocess.run(["/tmp/isoview_make_extra"], check=True)
# pyopenvdb reads the same values as from the originals (checked here: same reference files).
add("dense_zip.vdb", **reference("dense_zip.vdb", "dense", "dense_zip"))
assert open("dense_zip.f32", "rb").read() == open("dense.f32", "rb").read()
os.remove("dense_zip.f32")
REF["dense_zip.vdb"]["values"] = "dense.f32"
assert "zip" in subprocess.run(["vdb_print", "-m", "dense_zip.vdb"], capture_output=True,
                               text=True, check=True).stdout
add("torus_zip.vdb", **reference("torus_zip.vdb", torus, "torus_zip"))
assert open("torus_zip.f32", "rb").read() == open("torus.f32", "rb").read()
os.remove("torus_zip.f32")
REF["torus_zip.vdb"]["values"] = "torus.f32"
# pyopenvdb reads no double grid: its reference is the float sphere's (each float exact).
add("sphere_double.vdb", **REF["sphere.vdb"])

# A fog volume: the sphere turned into density by vdb_tool.
vdb_tool("-read", "sphere.vdb", "-ls2fog", "-write", "fog.vdb")
fog = vdb.readAllGridMetadata("fog.vdb")[0].name
add("fog.vdb", **reference("fog.vdb", fog, "fog"))

# Several grids: two float grids and a vector grid.
small = vdb.createLevelSetSphere(radius=2.0, center=(0, 0, 0), voxelSize=0.5, halfWidth=2.0)
small.name = "small"
vec = vdb.Vec3SGrid()
vec.name = "velocity"
vec.getAccessor().setValueOn((0, 0, 0), (1.0, 2.0, 3.0))
vdb.write("multi.vdb", grids=[s, small, vec])
add("multi.vdb", refused="2 float or double grids")
add("multi.vdb#small", **reference("multi.vdb", "small", "multi_small"))
add("multi.vdb#velocity", refused="holds vec3s values")
add("multi.vdb#nothing", refused="no grid named")

# Only a vector grid.
vdb.write("vector.vdb", grids=[vec])
add("vector.vdb", refused="no float or double grid")

with open("reference.json", "w") as f:
    json.dump(REF, f, indent=1, sort_keys=True)
    f.write("\n")
