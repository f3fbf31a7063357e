#!/usr/bin/env python3
"""Writes the sample volumes used by scenes/volume-npy.toml and scenes/raw.toml.

Pure Python (no NumPy), so it runs on a fresh machine:

    python3 scenes/data/make_blobs.py

Both files sample the same field, a sum of four metaballs

    f(p) = sum_i r_i^2 / |p - c_i|^2        (f = 1 on a lone ball's sphere)

blobs.npy   shape (32, 32, 32), dtype uint8 ('|u1'), C order; element [i, j, k] is the value
            at the grid point (x_i, y_j, z_k) of [-1, 1]^3; value = min(255, round(50 f)),
            so the surface f = 2 (where the balls just merge) is the isovalue 100, inside
            "above".
blobs.raw   dims [20, 24, 28], u16 little endian, x fastest; point (i, j, k) sits at
            (-1 + i*2/19, -1.2 + j*2.4/23, -1.4 + k*2.8/27) (nearly cubic cells), and
            value = min(65535, round(5000 f)): again f = 2 is the isovalue 10000.
"""

import os
import struct

BALLS = [
    ((-0.35, -0.20, 0.10), 0.45),
    ((0.40, 0.10, -0.20), 0.40),
    ((0.00, 0.45, 0.35), 0.35),
    ((0.10, -0.45, -0.35), 0.30),
]


def field(x, y, z):
    total = 0.0
    for (cx, cy, cz), r in BALLS:
        d2 = (x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2
        total += r * r / max(d2, 1e-6)
    return total


def npy_bytes(descr, shape, payload):
    """An .npy version 1.0 file: magic, header dict padded to a multiple of 64, payload."""
    header = "{'descr': '%s', 'fortran_order': False, 'shape': (%s), }" % (
        descr,
        ", ".join(str(n) for n in shape),
    )
    pad = 64 - (10 + len(header) + 1) % 64
    header = header + " " * (pad % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode("ascii") + payload


def make_npy(path, n=32):
    # C order: the last index (k, along z) varies fastest.
    out = bytearray()
    for i in range(n):
        x = -1.0 + 2.0 * i / (n - 1)
        for j in range(n):
            y = -1.0 + 2.0 * j / (n - 1)
            for k in range(n):
                z = -1.0 + 2.0 * k / (n - 1)
                out.append(min(255, int(round(50.0 * field(x, y, z)))))
    with open(path, "wb") as f:
        f.write(npy_bytes("|u1", (n, n, n), bytes(out)))


def make_raw(path, dims=(20, 24, 28), half=(1.0, 1.2, 1.4)):
    nx, ny, nz = dims
    out = bytearray()
    for k in range(nz):
        z = -half[2] + 2.0 * half[2] * k / (nz - 1)
        for j in range(ny):
            y = -half[1] + 2.0 * half[1] * j / (ny - 1)
            for i in range(nx):
                x = -half[0] + 2.0 * half[0] * i / (nx - 1)
                out += struct.pack("<H", min(65535, int(round(5000.0 * field(x, y, z)))))
    with open(path, "wb") as f:
        f.write(bytes(out))


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    make_npy(os.path.join(here, "blobs.npy"))
    make_raw(os.path.join(here, "blobs.raw"))
