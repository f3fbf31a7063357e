#!/usr/bin/env python3
"""Writes the test volumes of tests/data/formats/ with each format's reference tools (Teem's
unu, SimpleITK, VTK, nibabel, tifffile) and copies the real files shipped by packages. Run
from this folder with a Python that has: nibabel mrcfile pynrrd SimpleITK tifffile vtk, and
teem-unu on PATH (Debian teem-apps). PKG points at the unpacked package files (README.md).

    python3 make_files.py /tmp/dl
"""
import os
import shutil
import subprocess
import sys

import nibabel as nib
import numpy as np
import SimpleITK as sitk
import tifffile
import vtk
from vtk.util import numpy_support

PKG = sys.argv[1] if len(sys.argv) > 1 else "/tmp/dl"

os.makedirs("types", exist_ok=True)

# Real files from packages (origins and licences: README.md).
for src, dst in [
    ("/usr/lib/python3/dist-packages/nibabel/tests/data/anatomical.nii", "anatomical.nii"),
    ("/usr/lib/python3/dist-packages/nibabel/tests/data/standard.nii.gz", "standard.nii.gz"),
    ("/usr/lib/python3/dist-packages/skimage/data/_blobs_3d_fiji_skeleton.tif", "blobs_3d_fiji_skeleton.tif"),
    (f"{PKG}/mrcfile-1.5.4/tests/test_data/EMD-3197.map", "EMD-3197.map"),
    (f"{PKG}/mrcfile-1.5.4/tests/test_data/EMD-3001.map", "EMD-3001.map"),
    (f"{PKG}/pyvista/examples/uniform.vtk", "uniform.vtk"),
]:
    shutil.copyfile(src, dst)

# One smooth field, not symmetric in any axis, so a transposed or flipped read shows.
NX, NY, NZ = 12, 10, 8
k, j, i = np.meshgrid(np.arange(NZ), np.arange(NY), np.arange(NX), indexing="ij")
field = (np.sqrt((i - 5.2) ** 2 + (1.3 * (j - 4.1)) ** 2 + (1.7 * (k - 3.3)) ** 2) * 10 + i * 0.5 - j * 0.25)
# field[k, j, i]: x fastest in C order.

# An oblique frame: rotation 30 deg about z then 20 deg about x, spacing (0.8, 1.1, 1.6).
a, b = np.radians(30), np.radians(20)
rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
R = rx @ rz  # columns: the directions of the grid axes
SP = np.array([0.8, 1.1, 1.6])
ORIGIN = np.array([-12.5, 7.25, 30.0])

def unu(*args, data=None):
    subprocess.run(["teem-unu", *args], input=data, check=True)

# NRRD by Teem's unu: raw big-endian int16 with space directions; gzip float oblique;
# ascii uchar with spacings; a detached header with uint16 data.
dirs = " ".join("(%s)" % ",".join("%.17g" % v for v in R[:, c] * SP[c]) for c in range(3))
orig = "(%s)" % ",".join("%.17g" % v for v in ORIGIN)
field.astype(">i2").tofile("tmp.raw")
unu("make", "-i", "tmp.raw", "-t", "short", "-s", str(NX), str(NY), str(NZ), "-e", "raw", "-en", "big",
    "-spc", "LPS", "-orig", "(1,2,3)", "-dirs", "(0.5,0,0) (0,0.75,0) (0,0,1.25)", "-o", "unu_raw_be.nrrd")
(field.astype("<f4") * 0.01).tofile("tmp.raw")
unu("make", "-i", "tmp.raw", "-t", "float", "-s", str(NX), str(NY), str(NZ), "-e", "raw", "-en", "little",
    "-spc", "RAS", "-orig", orig, "-dirs", dirs, "-o", "tmp.nrrd")
unu("save", "-i", "tmp.nrrd", "-f", "nrrd", "-e", "gzip", "-o", "unu_gzip_oblique.nrrd")
field.astype("u1").tofile("tmp.raw")
unu("make", "-i", "tmp.raw", "-t", "uchar", "-s", str(NX), str(NY), str(NZ), "-e", "raw",
    "-sp", "0.5", "2", "1.5", "-o", "tmp.nrrd")
unu("save", "-i", "tmp.nrrd", "-f", "nrrd", "-e", "ascii", "-o", "unu_ascii.nrrd")
field.astype("<u2").tofile("unu_detached.raw")
unu("make", "-h", "-i", "unu_detached.raw", "-t", "ushort", "-s", str(NX), str(NY), str(NZ), "-e", "raw",
    "-en", "little", "-sp", "1", "1", "2", "-o", "unu_detached.nhdr")
for f in ["tmp.raw", "tmp.nrrd"]:
    os.remove(f)

# SimpleITK: NRRD (gzip, LPS, oblique), MetaImage .mha (zlib) and .mhd + .raw.
img = sitk.GetImageFromArray(field.astype(np.float32))  # array [k, j, i] -> image (x, y, z)
img.SetSpacing(SP.tolist())
img.SetOrigin(ORIGIN.tolist())
img.SetDirection(R.flatten().tolist())  # row-major matrix, columns = axis directions
sitk.WriteImage(img, "sitk_oblique.nrrd", useCompression=True)
sitk.WriteImage(img, "sitk_oblique.mha", useCompression=True)
img16 = sitk.GetImageFromArray(field.astype(np.int16))
img16.SetSpacing([0.9, 0.9, 2.5])
img16.SetOrigin([10.0, -20.0, 5.0])
sitk.WriteImage(img16, "sitk_int16.mhd", useCompression=False)

# VTK XML image data in each encoding, with an oblique Direction and an extent not at 0.
def vti(name, mode, compress, header64=False, big_endian=False):
    im = vtk.vtkImageData()
    im.SetExtent(2, 2 + NX - 1, -1, -1 + NY - 1, 0, NZ - 1)
    im.SetOrigin(*ORIGIN)
    im.SetSpacing(*SP)
    im.SetDirectionMatrix(*R.flatten())
    arr = numpy_support.numpy_to_vtk(field.ravel().astype(np.float64), deep=True)
    arr.SetName("density")
    im.GetPointData().SetScalars(arr)
    w = vtk.vtkXMLImageDataWriter()
    w.SetFileName(name)
    w.SetInputData(im)
    {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary,
     "appended": w.SetDataModeToAppended}[mode]()
    if mode == "appended":
        w.SetEncodeAppendedData(name.endswith("base64.vti"))
    if not compress:
        w.SetCompressorTypeToNone()
    if header64:
        w.SetHeaderTypeToUInt64()
    if big_endian:
        w.SetByteOrderToBigEndian()
    assert w.Write() == 1
vti("vtk_ascii.vti", "ascii", False)
vti("vtk_binary.vti", "binary", False)
vti("vtk_binary_zlib.vti", "binary", True, header64=True)
vti("vtk_appended_raw.vti", "appended", False)
vti("vtk_appended_raw_zlib.vti", "appended", True)
vti("vtk_appended_base64.vti", "appended", True)
vti("vtk_bigendian_zlib.vti", "binary", True, big_endian=True)

# Legacy VTK, ASCII (pyvista's uniform.vtk above is the binary one).
sp = vtk.vtkStructuredPoints()
sp.SetDimensions(NX, NY, NZ)
sp.SetOrigin(1.0, 2.0, 3.0)
sp.SetSpacing(0.5, 0.25, 2.0)
arr = numpy_support.numpy_to_vtk(field.ravel().astype(np.float32), deep=True)
arr.SetName("density")
sp.GetPointData().SetScalars(arr)
w = vtk.vtkStructuredPointsWriter()
w.SetFileName("vtk_ascii.vtk")
w.SetInputData(sp)
w.SetFileTypeToASCII()
w.Write()

# NIfTI by nibabel: a qform-only oblique float32 .nii.gz (qfac -1) and an sform int16 .nii.
aff = np.eye(4)
aff[:3, :3] = R @ np.diag(SP)
aff[:3, 3] = ORIGIN
aff_lh = aff.copy()
aff_lh[:3, 2] *= -1  # left-handed: qfac = -1
vol = np.transpose(field, (2, 1, 0))  # nibabel arrays are [i, j, k]
q = nib.Nifti1Image(vol.astype(np.float32), None)
q.set_qform(aff_lh, code=1)
q.set_sform(None, code=0)
nib.save(q, "nibabel_qform.nii.gz")
s = nib.Nifti1Image(vol.astype(np.int16), None)
s.set_sform(aff, code=2)
s.set_qform(None, code=0)
s.header.set_slope_inter(0.5, -3.0)
nib.save(s, "nibabel_sform_scaled.nii")

# TIFF stacks by tifffile: float32 and uint16 pages.
tifffile.imwrite("tifffile_f32.tif", field.astype(np.float32))
tifffile.imwrite("tifffile_u16.tif", field.astype(np.uint16), compression="zlib")

# Every scalar type, small (3x2x2, signed values where the type has a sign), by each tool.
small = (field[:2, :2, :3] - 60.0) * 1.5  # [k, j, i]
for t, np_t, en in [("signed char", "i1", "little"), ("uchar", "u1", "little"), ("short", "i2", "big"),
                    ("ushort", "u2", "little"), ("int", "i4", "big"), ("uint", "u4", "little"),
                    ("longlong", "i8", "little"), ("ulonglong", "u8", "big"),
                    ("float", "f4", "big"), ("double", "f8", "little")]:
    v = np.abs(small) if np_t.startswith("u") else small
    (v.astype(np_t)).astype(("<" if en == "little" else ">") + np_t).tofile("tmp.raw")
    unu("make", "-i", "tmp.raw", "-t", t, "-s", "3", "2", "2", "-e", "raw", "-en", en,
        "-o", f"types/unu_{t.replace(' ', '_')}.nrrd")
os.remove("tmp.raw")
import mrcfile
for mode, np_t in [(0, np.int8), (1, np.int16), (2, np.float32), (6, np.uint16), (12, np.float16)]:
    v = np.abs(small) if np_t == np.uint16 else small
    with mrcfile.new(f"types/mrcfile_mode{mode}.mrc", overwrite=True) as m:
        m.set_data(v.astype(np_t))  # [section, row, column]
        m.voxel_size = (1.5, 2.0, 2.5)
for np_t in [np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32, np.int64, np.uint64,
             np.float32, np.float64]:
    v = np.abs(small) if np.dtype(np_t).kind == "u" else small
    img = nib.Nifti1Image(np.transpose(v, (2, 1, 0)).astype(np_t), np.diag([1.5, 2.0, 2.5, 1.0]),
                          dtype=np_t)
    nib.save(img, f"types/nibabel_{np.dtype(np_t).name}.nii")
for px, name in [(sitk.sitkInt8, "int8"), (sitk.sitkUInt8, "uint8"), (sitk.sitkUInt16, "uint16"),
                 (sitk.sitkInt32, "int32"), (sitk.sitkUInt32, "uint32"), (sitk.sitkFloat64, "float64")]:
    im = sitk.Cast(sitk.GetImageFromArray(np.abs(small) if name.startswith("u") else small), px)
    sitk.WriteImage(im, f"types/sitk_{name}.mha")
for vtk_t, name in [(np.int8, "Int8"), (np.uint8, "UInt8"), (np.int16, "Int16"), (np.uint16, "UInt16"),
                    (np.int32, "Int32"), (np.uint32, "UInt32"), (np.int64, "Int64"), (np.float32, "Float32")]:
    im = vtk.vtkImageData()
    im.SetDimensions(3, 2, 2)
    v = np.abs(small) if name.startswith("U") else small
    arr = numpy_support.numpy_to_vtk(v.ravel().astype(vtk_t), deep=True)
    arr.SetName("v")
    im.GetPointData().SetScalars(arr)
    w = vtk.vtkXMLImageDataWriter()
    w.SetFileName(f"types/vtk_{name}.vti")
    w.SetInputData(im)
    w.SetDataModeToAppended()
    w.SetEncodeAppendedData(False)
    assert w.Write() == 1
for np_t in [np.int8, np.int16, np.uint32, np.int32, np.float64]:
    v = np.abs(small) if np.dtype(np_t).kind == "u" else small
    tifffile.imwrite(f"types/tifffile_{np.dtype(np_t).name}.tif", v.astype(np_t), photometric="minisblack")
