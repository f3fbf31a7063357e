"""Large data: isoview's brick pool (`field.residency = "active"`) on grids that do and do not
fit, one run, same machine. Started by benches/large/run. Nothing is asserted about times.

Tables (markdown, also written to OUT/results.md):
  1. active fraction: a 256^3 torus SDF (npy, C order) at several isovalues, analytic, 512x512:
     the whole grid (3D image) vs the pool, GPU ms, process s, pool size, scan and upload time,
     and whether the two EXRs are byte-identical;
  2. grids larger than the cap / the device: a dense 1024^3 sphere SDF (4 GiB raw) and a sparse
     2048^3 one (32 GiB raw, holes outside a sphere of radius 300), analytic and fixed-step,
     with peak resident memory (`/usr/bin/time -f %M`).
"""

import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

OUT = Path(sys.argv[1])
ISOVIEW = sys.argv[2]
REPEAT = int(os.environ.get("LARGE_REPEAT", "1"))
SIZE = 512


def torus(x, y, z):
    ring = np.sqrt(x * x + z * z) - 0.6
    return np.sqrt(ring * ring + y * y) - 0.25


def write_torus():
    path = OUT / "torus-256.npy"
    if not path.exists():
        c = np.linspace(-1.0, 1.0, 256)
        x, y, z = np.meshgrid(c, c, c, indexing="ij")
        np.save(path, torus(x, y, z).astype(np.float32))
    (OUT / "torus.toml").write_text(
        '[camera]\neye = [2.2, 1.6, 2.4]\ntarget = [0.0, 0.0, 0.0]\nfov_y_deg = 40.0\n'
        '[field]\nsource = "npy"\npath = "torus-256.npy"\n'
        'bounds = { min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }\n'
    )


def write_dense(n=1024):
    path = OUT / f"sphere-{n}.raw"
    c, r = (n - 1) / 2, 0.4 * (n - 1)
    if not path.exists() or path.stat().st_size != 4 * n**3:
        x = np.arange(n, dtype=np.float64) - c
        yy, xx = np.meshgrid(x, x, indexing="ij")
        with open(path, "wb") as f:
            for z in range(n):
                f.write((np.sqrt(xx * xx + yy * yy + (z - c) ** 2) - r).astype("<f4").tobytes())
    (OUT / "dense.toml").write_text(
        f'[camera]\neye = [{1.47*n}, {1.17*n}, {1.66*n}]\ntarget = [{c}, {c}, {c}]\n'
        f'fov_y_deg = 40.0\n[field]\nsource = "raw"\npath = "{path.name}"\n'
        f'dims = [{n}, {n}, {n}]\ndtype = "f32"\nresidency = "active"\n'
    )


def write_sparse(n=2048, r=300.0):
    """Holes (0.0) outside a sphere, min(|p - c| - r, 0) clamped at -4 inside: isovalue -2 is the
    sphere of radius r - 2; only the ball's rows are written."""
    path = OUT / f"sphere-{n}-sparse.raw"
    if not path.exists() or path.stat().st_size != 4 * n**3:
        c = (n - 1) / 2
        with open(path, "wb") as f:
            f.truncate(4 * n**3)
            for z in range(int(c - r) - 1, int(c + r) + 2):
                dz = z - c
                for y in range(int(c - r) - 1, int(c + r) + 2):
                    dy = y - c
                    rx2 = r * r - dz * dz - dy * dy
                    if rx2 <= 0:
                        continue
                    rx = np.sqrt(rx2)
                    x0, x1 = max(int(c - rx) - 1, 0), min(int(c + rx) + 2, n)
                    x = np.arange(x0, x1, dtype=np.float64) - c
                    v = np.clip(np.sqrt(x * x + dy * dy + dz * dz) - r, -4.0, 0.0)
                    f.seek(4 * (x0 + n * (y + n * z)))
                    f.write(v.astype("<f4").tobytes())
    c = (n - 1) / 2
    (OUT / "sparse.toml").write_text(
        f'[camera]\neye = [{1.47*n}, {1.17*n}, {1.66*n}]\ntarget = [{c}, {c}, {c}]\n'
        f'fov_y_deg = 30.0\n[field]\nsource = "raw"\npath = "{path.name}"\n'
        f'dims = [{n}, {n}, {n}]\ndtype = "f32"\nresidency = "active"\n'
        '[surface]\nisovalue = -2.0\n'
    )


def run(scene, out, sets):
    args = ["/usr/bin/time", "-f", "maxrss_kb=%M", ISOVIEW, "render", str(OUT / scene),
            "-o", str(OUT / out), "--set", f"image.width={SIZE}", "--set", f"image.height={SIZE}"]
    for s in sets:
        args += ["--set", s]
    t = time.monotonic()
    p = subprocess.run(args, capture_output=True, text=True)
    wall = time.monotonic() - t
    if p.returncode != 0:
        sys.exit(f"large: {' '.join(args)} failed:\n{p.stderr}")
    err = p.stderr
    gpu = float(re.search(r"GPU ([0-9.]+) ms", err).group(1))
    rss = int(re.search(r"maxrss_kb=(\d+)", err).group(1)) / 1024
    pool = re.search(r"(\d+) of (\d+) bricks .* active, (\d+) resident, ([0-9.]+) MiB pool "
                     r"\(scan ([0-9.]+) s, upload ([0-9.]+) s\)", err)
    return {"gpu": gpu, "wall": wall, "rss": rss, "pool": pool and pool.groups()}


def median_run(scene, out, sets):
    runs = [run(scene, out, sets) for _ in range(REPEAT)]
    best = dict(runs[0])
    best["gpu"] = statistics.median(r["gpu"] for r in runs)
    best["wall"] = statistics.median(r["wall"] for r in runs)
    return best


def main():
    lines = []
    say = lambda s="": (print(s, flush=True), lines.append(s))
    load = os.getloadavg()[0]
    say(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {os.cpu_count()} cores; "
        f"load average {load:.2f} at start; medians of {REPEAT}.")
    say()
    write_torus()
    say("**Active fraction: 256³ torus SDF (npy), analytic, 512×512, whole grid vs brick pool**")
    say()
    say("| isovalue | active bricks | pool MiB | scan + upload s | whole GPU ms | pool GPU ms "
        "| pool / whole | whole process s | pool process s | EXR identical |")
    say("|---|---|---|---|---|---|---|---|---|---|")
    for iso in [-0.2, 0.0, 0.1, 0.25, 0.5]:
        s = [f"surface.isovalue={iso}"]
        w = median_run("torus.toml", "whole.exr", s)
        p = median_run("torus.toml", "pool.exr", s + ['field.residency="active"'])
        same = (OUT / "whole.exr").read_bytes() == (OUT / "pool.exr").read_bytes()
        act, total, _res, mib, scan, up = p["pool"]
        say(f"| {iso} | {int(act):,} of {int(total):,} ({100*int(act)/int(total):.1f}%) | {mib} "
            f"| {float(scan) + float(up):.2f} | {w['gpu']:.0f} | {p['gpu']:.0f} "
            f"| {p['gpu']/w['gpu']:.2f}× | {w['wall']:.2f} | {p['wall']:.2f} | {'yes' if same else 'NO'} |")
    say()
    write_dense()
    write_sparse()
    say("**Grids over the cap (1024 MiB) and over lavapipe's heap (2 GiB), 512×512, brick pool**")
    say()
    say("| grid | method | active bricks | resident | pool MiB | scan s | upload s | GPU ms "
        "| process s | peak RSS MiB |")
    say("|---|---|---|---|---|---|---|---|---|---|")
    for scene, name in [("dense.toml", "1024³ sphere SDF, dense (4 GiB)"),
                        ("sparse.toml", "2048³ sphere, sparse file (32 GiB, 2.2 GB on disk)")]:
        for method, sets in [("analytic", []),
                             ("fixed-step, 1024 steps", ['render.method="fixed-step"', "render.steps=1024"])]:
            r = run(scene, "big.exr", sets)
            act, total, res, mib, scan, up = r["pool"]
            say(f"| {name} | {method} | {int(act):,} of {int(total):,} | {int(res):,} | {mib} "
                f"| {scan} | {up} | {r['gpu']:.0f} | {r['wall']:.1f} | {r['rss']:.0f} |")
    say()
    say("**Extraction from the mapped file (marching cubes, binary PLY), whole process**")
    say()
    say("| grid | vertices | triangles | process s | peak RSS MiB |")
    say("|---|---|---|---|---|")
    for scene, name in [("dense.toml", "1024³ sphere SDF, dense (4 GiB)"),
                        ("sparse.toml", "2048³ sphere, sparse file (32 GiB, 2.2 GB on disk)")]:
        args = ["/usr/bin/time", "-f", "maxrss_kb=%M", ISOVIEW, "extract", str(OUT / scene),
                "-o", str(OUT / "big.ply")]
        t = time.monotonic()
        p = subprocess.run(args, capture_output=True, text=True)
        wall = time.monotonic() - t
        if p.returncode != 0:
            sys.exit(f"large: {' '.join(args)} failed:\n{p.stderr}")
        m = re.search(r"(\d+) vertices, (\d+) triangles", p.stderr)
        rss = int(re.search(r"maxrss_kb=(\d+)", p.stderr).group(1)) / 1024
        say(f"| {name} | {int(m.group(1)):,} | {int(m.group(2)):,} | {wall:.1f} | {rss:.0f} |")
    (OUT / "big.ply").unlink(missing_ok=True)
    (OUT / "big.exr").unlink(missing_ok=True)
    say()
    say(f"Load average {os.getloadavg()[0]:.2f} at the end.")
    (OUT / "results.md").write_text("\n".join(lines) + "\n")


main()
