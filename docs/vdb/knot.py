#!/usr/bin/env python3
"""Writes a trefoil-knot tube as an OBJ triangle mesh (stdout): the showcase's mesh, which
vdb_tool -mesh2ls turns into a level set (docs/vdb/showcase.sh). No dependencies."""

import math
import sys

N, M, R = 720, 48, 0.32  # segments along the knot, around the tube; tube radius


def knot(t):
    return (math.sin(t) + 2 * math.sin(2 * t), math.cos(t) - 2 * math.cos(2 * t), -math.sin(3 * t))


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def unit(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


out = sys.stdout
for i in range(N):
    t = 2 * math.pi * i / N
    p, q = knot(t), knot(t + 1e-4)
    tangent = unit(sub(q, p))
    normal = unit(cross(tangent, [0.0, 0.0, 1.0]))
    binormal = cross(tangent, normal)
    for j in range(M):
        a = 2 * math.pi * j / M
        v = [p[k] + R * (math.cos(a) * normal[k] + math.sin(a) * binormal[k]) for k in range(3)]
        out.write("v %.6f %.6f %.6f\n" % tuple(v))
for i in range(N):
    for j in range(M):
        a = i * M + j + 1
        b = ((i + 1) % N) * M + j + 1
        c = ((i + 1) % N) * M + (j + 1) % M + 1
        d = i * M + (j + 1) % M + 1
        out.write("f %d %d %d\nf %d %d %d\n" % (a, b, c, a, c, d))
