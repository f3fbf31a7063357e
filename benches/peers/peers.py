"""isoview against its peers, same machine, same inputs, one run. Started by benches/peers/run.

Jobs (each prints one markdown table; all go to OUT/results.md):
  1. ray tracing: `isoview render` (analytic, 512x512) vs Mitsuba 3 `sdfgrid`
     `scene.ray_intersect` on the same pixel-centre rays, with hit and depth agreement;
  2. analytic vs fixed-step (steps = 512) on the 256^3 gyroid;
  3. extraction, whole process: `isoview extract` (default device, --device cpu, --device gpu) vs
     np.load + scikit-image marching_cubes + trimesh PLY, timed from outside the same way;
  4. extraction alone: VTK vtkFlyingEdges3D (Update() only) and skimage marching_cubes.
Times are medians of PEERS_REPEAT runs (default 5). Nothing is asserted about them.
"""

import argparse
import os
import platform
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

LO, HI = -1.0, 1.0  # every grid spans the cube [LO, HI]^3 (Mitsuba's sdfgrid needs cubes)
DIAGONAL = (HI - LO) * 3**0.5
SIZE = 512
REPEAT = int(os.environ.get("PEERS_REPEAT", "5"))
HERE = Path(__file__).resolve().parent


def torus(x, y, z):
    """The torus of scenes/torus.toml: ring in the xz-plane, R = 0.6, r = 0.25."""
    ring = np.sqrt(x * x + z * z) - 0.6
    return np.sqrt(ring * ring + y * y) - 0.25


def gyroid(x, y, z):
    """The thickened gyroid of scenes/gyroid.toml (scale 6, thickness 0.08)."""
    s = 6.0
    g = np.sin(s * x) * np.cos(s * y) + np.sin(s * y) * np.cos(s * z) + np.sin(s * z) * np.cos(s * x)
    return np.abs(g) / s - 0.08


# name: (field, points per axis, eye); target the origin, up +y, fov 40 degrees.
INPUTS = {
    "torus-64": (torus, 64, (2.2, 1.6, 2.4)),
    "torus-256": (torus, 256, (2.2, 1.6, 2.4)),
    "gyroid-256": (gyroid, 256, (3.0, 2.3, 3.3)),
}
FOV_Y = 40.0


def make_inputs(out):
    """Writes NAME.npy (f32, vol[i, j, k] = f(x_i, y_j, z_k)) and NAME.toml for every input."""
    for name, (f, n, eye) in INPUTS.items():
        c = np.linspace(LO, HI, n)  # point i at LO + i (HI - LO) / (n - 1), as isoview
        x, y, z = np.meshgrid(c, c, c, indexing="ij")
        np.save(out / f"{name}.npy", f(x, y, z).astype(np.float32))
        # Method and size come from --set on the command line; the scene holds the rest.
        (out / f"{name}.toml").write_text(
            f"""# Written by benches/peers/peers.py.
[camera]
eye = [{eye[0]}, {eye[1]}, {eye[2]}]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y_deg = {FOV_Y}

[field]
source = "npy"
path = "{name}.npy"
bounds = {{ min = [{LO}, {LO}, {LO}], max = [{HI}, {HI}, {HI}] }}

[surface]
isovalue = 0.0
inside = "below"
"""
        )


def pixel_rays(eye, w, h):
    """Pixel-centre rays of docs/methods.md "Conventions" (camera), row 0 at the top: origins, unit dirs."""
    eye = np.array(eye, dtype=np.float64)
    fwd = -eye / np.linalg.norm(eye)  # target is the origin
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    th = np.tan(np.radians(FOV_Y) / 2)
    px, py = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    u = ((2 * px / w - 1) * th * (w / h)).ravel()
    v = ((1 - 2 * py / h) * th).ravel()
    d = fwd + u[:, None] * right + v[:, None] * up
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.broadcast_to(eye, d.shape), d


def timed(cmd, env=None):
    """Runs a process (with `env` added to the environment), fails loudly if it fails; returns
    (wall seconds, stdout, stderr)."""
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **(env or {})})
    wall = time.perf_counter() - t
    if p.returncode != 0:
        sys.exit(f"peers: failed ({p.returncode}): {' '.join(map(str, cmd))}\n{p.stderr}{p.stdout}")
    return wall, p.stdout, p.stderr


def median(xs):
    return statistics.median(xs)


def render(iso, out, name, *sets):
    """`isoview render` REPEAT times: median GPU ms (Vulkan timestamps, printed by isoview: all
    device work of the render, the structures it builds included), median trace GPU ms and build
    ms (the structures: the brick grid, made by the CPU on a CPU device, and the occupancy
    structure; `ISOVIEW_TIMINGS=1`'s line), median whole-process s, the EXR."""
    exr = out / f"{name}.{'-'.join(s.split('=')[1] for s in sets)}.exr"  # name.fixed-step-512.exr
    cmd = [iso, "render", out / f"{name}.toml", "-o", exr,
           "--set", f"image.width={SIZE}", "--set", f"image.height={SIZE}"]
    for s in sets:
        cmd += ["--set", s]
    gpu, wall, trace, build = [], [], [], []
    for _ in range(REPEAT):
        w, _, err = timed(cmd, {"ISOVIEW_TIMINGS": "1"})
        m = re.search(r"\(GPU ([0-9.]+) ms\)", err)
        t = re.search(r"GPU build ([0-9.]+) ms \(brick grid ([0-9.]+) ms, occupancy ([0-9.]+) ms\), "
                      r"trace ([0-9.]+) ms(; brick grid made on the CPU in ([0-9.]+) ms)?", err)
        if not m or not t:
            sys.exit(f"peers: no GPU time in isoview's output: {err}")
        gpu.append(float(m.group(1)))
        trace.append(float(t.group(4)))
        # The structures: on the device, or the brick grid by the CPU on a CPU device.
        build.append(float(t.group(1)) + float(t.group(6) or 0.0))
        wall.append(w)
    return median(gpu), median(wall), read_z(exr), median(trace), median(build)


def read_z(exr):
    """The Z channel (distance along the unit ray; +inf on a miss) as an array of rows."""
    import OpenEXR

    with OpenEXR.File(str(exr)) as f:
        return np.array(f.channels()["Z"].pixels, dtype=np.float64)


def mitsuba_trace(vol, eye):
    """Mitsuba's sdfgrid on the same grid and rays: ms per ray_intersect evaluating the depth
    alone, ms evaluating depth, position and normal, scene load ms, depth image (+inf: miss)."""
    import drjit as dr
    import mitsuba as mi

    # Mitsuba wants data[z][y][x][1] over the unit cube, values in that cube's units.
    data = np.ascontiguousarray(vol.transpose(2, 1, 0)[..., None] / (HI - LO), dtype=np.float32)
    to_world = mi.ScalarTransform4f().translate([LO] * 3).scale([HI - LO] * 3)
    t = time.perf_counter()
    scene = mi.load_dict({"type": "scene",
                          "grid": {"type": "sdfgrid", "grid": mi.TensorXf(data), "to_world": to_world}})
    load_ms = (time.perf_counter() - t) * 1e3
    o, d = pixel_rays(eye, SIZE, SIZE)
    ray = mi.Ray3f(mi.Point3f(*(mi.Float(c) for c in o.T.astype(np.float32))),
                   mi.Vector3f(*(mi.Float(c) for c in d.T.astype(np.float32))))
    dr.eval(ray)  # build the rays before the clock starts
    dr.sync_thread()

    def trace(outputs):
        si = scene.ray_intersect(ray)
        dr.eval(*outputs(si))  # evaluation is lazy: force what is asked for, and only that
        dr.sync_thread()
        return si

    def clock(outputs):
        # Warm-up: Dr.Jit compiles its kernels on the first call, and a call or two after it
        # were still seen to take several times longer here.
        for _ in range(3):
            trace(outputs)
        times = []
        for _ in range(REPEAT):
            t = time.perf_counter()
            trace(outputs)
            times.append((time.perf_counter() - t) * 1e3)
        return median(times)

    # The depth alone (the least Mitsuba can be asked for), and depth, position and normal (what
    # isoview writes too, besides shading).
    t_ms = clock(lambda si: (si.t,))
    tpn_ms = clock(lambda si: (si.t, si.p, si.sh_frame.n))
    si = trace(lambda si: (si.t,))
    hit = np.array(si.is_valid())
    depth = np.where(hit, np.array(si.t), np.inf)
    return t_ms, tpn_ms, load_ms, depth.reshape(SIZE, SIZE)


def agreement(za, zb):
    """Hit agreement "same / pixels (percent)", and |depth difference| / diagonal on the pixels
    both hit: 99th percentile, max, and how many exceed 1e-5 (docs/methods.md's tolerance for analytic)."""
    ha, hb = np.isfinite(za), np.isfinite(zb)
    same = int((ha == hb).sum())
    dz = np.abs(za[ha & hb] - zb[ha & hb]) / DIAGONAL
    if dz.size == 0:
        return f"{same:,} / {za.size:,}", "", "", ""
    return (f"{same:,} / {za.size:,} ({100 * same / za.size:.3f}%)", f"{np.percentile(dz, 99):.1e}",
            f"{dz.max():.1e}", f"{int((dz > 1e-5).sum()):,}")


def table(title, header, rows):
    lines = [f"**{title}**", "", "| " + " | ".join(header) + " |",
             "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    text = "\n".join(lines) + "\n"
    print(text, flush=True)
    return text


def job_raytrace(iso, out):
    rows = []
    for name in INPUTS:
        f, n, eye = INPUTS[name]
        gpu, wall, z, trace, build = render(iso, out, name, "render.method=analytic")
        m_ms, m_tpn, m_load, mz = mitsuba_trace(np.load(out / f"{name}.npy"), eye)
        rows.append([f"{name.split('-')[0]} {n}³", f"{trace:.1f}", f"{build:.1f}", f"{gpu:.1f}",
                     f"{wall:.2f}", f"{m_ms:.1f}",
                     f"{m_tpn:.1f}", f"{m_load:.0f}", f"**{trace / m_ms:.2f}×**",
                     f"{int(np.isfinite(z).sum()):,}", f"{int(np.isfinite(mz).sum()):,}",
                     *agreement(z, mz)])
    return table(
        f"Ray tracing, {SIZE}×{SIZE}, one ray per pixel centre: isoview analytic vs Mitsuba 3 sdfgrid",
        ["grid", "isoview trace GPU ms", "isoview build ms", "isoview GPU ms (the summary's)",
         "isoview process s", "Mitsuba ray_intersect ms (depth)",
         "Mitsuba ms (depth, position, normal)", "Mitsuba scene load ms",
         "isoview trace / Mitsuba (depth)", "isoview hits", "Mitsuba hits", "hit agreement",
         "Δdepth / diagonal, p99", "Δdepth / diagonal, max", "pixels over 1e-5"], rows)


def job_fixed_step(iso, out):
    name = "gyroid-256"
    a_gpu, a_wall, az, a_trace, _ = render(iso, out, name, "render.method=analytic")
    f_gpu, f_wall, fz, _, _ = render(iso, out, name, "render.method=fixed-step", "render.steps=512",
                                     "render.skip=false")
    rows = [["analytic (trace; with its build)", f"{a_trace:.1f}; {a_gpu:.1f}", f"{a_wall:.2f}",
             f"{int(np.isfinite(az).sum()):,}", "", "", "", "", ""],
            ["fixed-step, steps = 512, skip = false", f"{f_gpu:.1f}", f"{f_wall:.2f}",
             f"{int(np.isfinite(fz).sum()):,}", *agreement(az, fz),
             f"**{a_trace / f_gpu:.2f}×** ({a_gpu / f_gpu:.2f}×)"]]
    return table(f"Analytic vs fixed-step (512 steps), gyroid 256³, {SIZE}×{SIZE}",
                 ["method", "GPU ms", "process s", "hits", "hit agreement with analytic",
                  "Δdepth / diagonal, p99", "Δdepth / diagonal, max", "pixels over 1e-5",
                  "analytic / fixed-step GPU time (trace; with the build)"], rows)


def job_extract_process(iso, out):
    npy, scene = out / "gyroid-256.npy", out / "gyroid-256.toml"

    def isoview(*dev):
        runs = [timed([iso, "extract", scene, "-o", out / "isoview.ply", *dev]) for _ in range(REPEAT)]
        m = re.search(r"(\d+) vertices, (\d+) triangles \(\S+ on (\w+)[;)].* in (\d+) ms", runs[-1][2])
        if not m:
            sys.exit(f"peers: unexpected isoview extract output: {runs[-1][2]}")
        return median([r[0] for r in runs]), int(m[1]), int(m[2]), m[3], median(
            [float(re.search(r" in (\d+) ms", r[2])[1]) for r in runs])

    rows = []
    d_wall, d_v, d_t, d_on, d_own = isoview()
    c_wall, c_v, c_t, c_on, c_own = isoview("--device", "cpu")
    g_wall, g_v, g_t, g_on, g_own = isoview("--device", "gpu")
    runs = [timed([sys.executable, HERE / "skimage_extract.py", npy, out / "skimage.ply", str(LO), str(HI)])
            for _ in range(REPEAT)]
    s_wall = median([r[0] for r in runs])
    s_v, s_t = map(int, runs[-1][1].split())
    rows.append([f"`isoview extract` (default; ran on {d_on})", f"{d_wall:.2f}", f"{d_own:.0f}",
                 f"{d_v:,}", f"{d_t:,}", f"**{d_wall / s_wall:.2f}×**"])
    rows.append([f"`isoview extract --device cpu` (ran on {c_on})", f"{c_wall:.2f}", f"{c_own:.0f}",
                 f"{c_v:,}", f"{c_t:,}", f"{c_wall / s_wall:.2f}×"])
    rows.append([f"`isoview extract --device gpu` (ran on {g_on})", f"{g_wall:.2f}", f"{g_own:.0f}",
                 f"{g_v:,}", f"{g_t:,}", f"{g_wall / s_wall:.2f}×"])
    rows.append(["python: np.load + skimage `marching_cubes` + trimesh PLY", f"{s_wall:.2f}", "",
                 f"{s_v:,}", f"{s_t:,}", "1.00×"])
    return table("Marching cubes, gyroid 256³ npy → binary PLY, whole process (started and timed the same way)",
                 ["tool", "process s", "isoview's own ms (load + extract)", "vertices", "triangles",
                  "time / scikit-image"], rows)


def job_extract_alone(out):
    from skimage.measure import marching_cubes
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonCore import vtkSMPTools
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkFiltersCore import vtkFlyingEdges3D

    vol = np.load(out / "gyroid-256.npy")
    n = vol.shape[0]
    h = (HI - LO) / (n - 1)
    img = vtkImageData()
    img.SetDimensions(*vol.shape)
    img.SetOrigin(LO, LO, LO)
    img.SetSpacing(h, h, h)
    img.GetPointData().SetScalars(numpy_to_vtk(vol.ravel(order="F"), deep=True))  # x fastest
    fe = vtkFlyingEdges3D()
    fe.SetInputData(img)
    fe.SetValue(0, 0.0)
    fe.ComputeNormalsOn()  # isoview and skimage give normals too
    fe.ComputeScalarsOff()
    rows = []
    # The wheel's default SMP backend is Sequential (one core); STDThread uses both.
    for backend in ("STDThread", "Sequential"):
        vtkSMPTools.SetBackend(backend)
        v_times = []
        for _ in range(REPEAT + 1):  # the first run is a warm-up (allocations, thread pool)
            fe.Modified()  # else Update() does nothing the second time
            t = time.perf_counter()
            fe.Update()
            v_times.append((time.perf_counter() - t) * 1e3)
        v_ms = median(v_times[1:])
        poly = fe.GetOutput()
        rows.append([f"VTK `vtkFlyingEdges3D`, `Update()` only, SMP backend {vtkSMPTools.GetBackend()}",
                     v_ms, f"{poly.GetNumberOfPoints():,}", f"{poly.GetNumberOfPolys():,}"])
    s_times = []
    for _ in range(REPEAT):
        t = time.perf_counter()
        verts, faces, _, _ = marching_cubes(vol, level=0.0, spacing=(h, h, h))
        s_times.append((time.perf_counter() - t) * 1e3)
    rows.append(["scikit-image `marching_cubes` (the call only)", median(s_times), f"{len(verts):,}",
                 f"{len(faces):,}"])
    base = min(rows[0][1], rows[1][1])  # the faster VTK backend on this machine, this run
    rows = [[r[0], f"{r[1]:.0f}", r[2], r[3], f"{r[1] / base:.2f}×"] for r in rows]
    return table("Extraction alone, gyroid 256³, already in memory",
                 ["tool", "ms", "vertices", "triangles", "time / faster VTK"], rows)


def machine(iso):
    import drjit
    import mitsuba
    import skimage
    import trimesh
    import vtkmodules

    info = timed([iso, "info"])[1].splitlines()
    device = next(l.split(None, 1)[1] for l in info if l.startswith("device "))
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")),
               platform.processor())
    return (f"{time.strftime('%Y-%m-%d %H:%M %Z')}; {cpu}, {os.cpu_count()} cores; "
            f"load average {os.getloadavg()[0]:.2f} at start; isoview device {device}; "
            f"mitsuba {mitsuba.__version__} (llvm_ad_rgb, drjit {drjit.__version__}, "
            f"{os.environ.get('DRJIT_LIBLLVM_PATH')}), scikit-image {skimage.__version__}, "
            f"trimesh {trimesh.__version__}, vtk {vtkmodules.__version__}, numpy {np.__version__}; "
            f"medians of {REPEAT}.")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isoview", required=True)
    ap.add_argument("--out", required=True, type=Path)
    args = ap.parse_args()
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")  # fails here, clearly, if Dr.Jit cannot load LLVM
    out = args.out
    started = time.perf_counter()
    print("peers: writing the inputs", file=sys.stderr, flush=True)
    make_inputs(out)
    head = machine(args.isoview)
    print(head + "\n", flush=True)
    parts = [head + "\n"]
    for job in (job_raytrace, job_fixed_step, job_extract_process):
        parts.append(job(args.isoview, out))
    parts.append(job_extract_alone(out))
    tail = f"Load average {os.getloadavg()[0]:.2f} at the end; {time.perf_counter() - started:.0f} s in all."
    print(tail)
    (out / "results.md").write_text("\n".join(parts) + "\n" + tail + "\n")
    print(f"peers: tables written to {out / 'results.md'}", file=sys.stderr)


if __name__ == "__main__":
    main()
