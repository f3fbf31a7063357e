#!/usr/bin/env python3
"""Reads every volume in this folder with its format's reference reader (nibabel, mrcfile,
pynrrd, SimpleITK, VTK, tifffile) and writes reference.json: dims, origin, spacing, unit axis
directions, and checksums (sum, min, max, values at a few grid points) of the samples as f32.
tests/it/field/formats.rs compares isoview's readers against it, so the tests need no Python.

    python3 make_reference.py      (a Python with nibabel mrcfile pynrrd SimpleITK tifffile vtk)
"""
import glob
import json

import mrcfile
import nibabel as nib
import nrrd
import numpy as np
import SimpleITK as sitk
import tifffile
import vtk
from vtk.util import numpy_support


def frame(origin, columns):
    """origin + per-axis step vectors -> origin, spacing, unit directions."""
    cols = [np.asarray(c, dtype=float) for c in columns]
    spacing = [float(np.linalg.norm(c)) for c in cols]
    return dict(origin=[float(v) for v in origin], spacing=spacing,
                axes=[[float(v) for v in c / n] for c, n in zip(cols, spacing)])


def read_nrrd(path):
    data, h = nrrd.read(path)  # data[i, j, k] (Fortran index order)
    if "space directions" in h:
        g = frame(h.get("space origin", np.zeros(3)), list(h["space directions"]))
    else:
        sp = h.get("spacings", np.ones(3))
        sp = [1.0 if np.isnan(s) else s for s in sp]
        mins = [0.0 if np.isnan(m) else m for m in h.get("axis mins", np.zeros(3))]
        g = frame(mins, [np.eye(3)[k] * sp[k] for k in range(3)])
    return data, g


def read_sitk(path):
    img = sitk.ReadImage(path)
    d = np.array(img.GetDirection()).reshape(3, 3)  # row-major, columns = axis directions
    sp = img.GetSpacing()
    g = frame(img.GetOrigin(), [d[:, k] * sp[k] for k in range(3)])
    return np.transpose(sitk.GetArrayFromImage(img), (2, 1, 0)), g


def read_vtk(path):
    r = vtk.vtkXMLImageDataReader() if path.endswith(".vti") else vtk.vtkStructuredPointsReader()
    r.SetFileName(path)
    r.Update()
    im = r.GetOutput()
    ext = im.GetExtent()
    nx, ny, nz = im.GetDimensions()
    d = np.array([[im.GetDirectionMatrix().GetElement(a, b) for b in range(3)] for a in range(3)])
    sp = im.GetSpacing()
    origin = [0.0, 0.0, 0.0]
    im.TransformIndexToPhysicalPoint(ext[0], ext[2], ext[4], origin)
    g = frame(origin, [d[:, k] * sp[k] for k in range(3)])
    arr = numpy_support.vtk_to_numpy(im.GetPointData().GetScalars())
    return arr.reshape(nz, ny, nx).transpose(2, 1, 0), g


def read_nifti(path):
    img = nib.load(path)
    h = img.header
    if h["sform_code"] > 0 or h["qform_code"] > 0:
        aff = img.affine
    else:  # the standard's method 1 (nibabel's own fallback is an Analyze affine)
        aff = np.diag(list(h.get_zooms()[:3]) + [1.0])
    data = np.asarray(img.dataobj, dtype=np.float64)  # scaled by scl_slope / scl_inter
    return data, frame(aff[:3, 3], [aff[:3, k] for k in range(3)])


def read_mrc(path):
    with mrcfile.open(path, permissive=False) as m:
        h = m.header
        stored = np.asarray(m.data)  # [section, row, column]
        order = [int(h.mapc) - 1, int(h.mapr) - 1, int(h.maps) - 1]  # column, row, section axes
        # data[x, y, z]: move the stored axes (column, row, section) onto x, y, z.
        data = np.moveaxis(stored.transpose(2, 1, 0), [0, 1, 2], order)
        vs = m.voxel_size
        spacing = np.array([vs.x, vs.y, vs.z], dtype=float)
        org = np.array([h.origin.x, h.origin.y, h.origin.z], dtype=float)
        if not org.any():
            start = np.zeros(3)
            for s, name in enumerate(["nxstart", "nystart", "nzstart"]):
                start[order[s]] = float(h[name])
            org = start * spacing
        g = frame(org, [np.eye(3)[k] * spacing[k] for k in range(3)])
    return data, g


def read_tiff(path):
    data = tifffile.imread(path)  # [page, row, column]
    return data.transpose(2, 1, 0), frame([0, 0, 0], np.eye(3))


READERS = {
    ".nrrd": ("nrrd", read_nrrd), ".nhdr": ("nrrd", read_nrrd),
    ".mha": ("metaimage", read_sitk), ".mhd": ("metaimage", read_sitk),
    ".vti": ("vti", read_vtk), ".vtk": ("vtk", read_vtk),
    ".nii": ("nifti", read_nifti), ".gz": ("nifti", read_nifti),
    ".map": ("mrc", read_mrc), ".mrc": ("mrc", read_mrc), ".tif": ("tiff", read_tiff),
}

out = {}
for path in sorted(glob.glob("*") + glob.glob("types/*")):
    ext = "." + path.rsplit(".", 1)[-1]
    if ext not in READERS:
        continue
    fmt, reader = READERS[ext]
    data, g = reader(path)
    v = np.asarray(data, dtype=np.float64).astype(np.float32)
    nx, ny, nz = v.shape
    points = [[0, 0, 0], [nx - 1, ny - 1, nz - 1], [nx // 2, ny // 3, nz // 4],
              [1, ny - 1, 0], [nx - 1, 0, nz // 2], [nx // 3, ny // 2, nz - 1]]
    out[path] = dict(format=fmt, dims=[nx, ny, nz], **g,
                     sum=float(v.astype(np.float64).sum()), min=float(v.min()), max=float(v.max()),
                     samples=[[p, float(v[tuple(p)])] for p in points])
with open("reference.json", "w") as f:
    json.dump(out, f, indent=1)
    f.write("\n")
print(f"{len(out)} files")
