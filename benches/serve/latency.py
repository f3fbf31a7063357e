#!/usr/bin/env python3
"""Progressive-rendering figures of `isoview serve` (docs/serve.md): for each shipped
scene at 512x512, the time from posting a changed isovalue to the coarse frame and to the full
frame arriving over HTTP, and the render thread's own times (the X-Isoview-Render-Ms and
X-Isoview-Gpu-Ms headers). Benchmark figures, not a test.

    benches/serve/latency.py [ISOVIEW_BINARY] [--runs N]     (default target/release/isoview)
"""
import http.client
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
args = [a for a in sys.argv[1:] if not a.startswith("--")]
BIN = Path(args[0]) if args else ROOT / "target/release/isoview"
RUNS = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else 5
SIZE = 512


def request(addr, token, method, path, body=None):
    host, port = addr.split(":")
    c = http.client.HTTPConnection(host, int(port), timeout=300)
    c.request(method, path, body=json.dumps(body) if body is not None else None,
              headers={"X-Isoview-Token": token})
    r = c.getresponse()
    data = r.read()
    c.close()
    return r.status, dict((k.lower(), v) for k, v in r.getheaders()), data


def bench(scene):
    sets = [f"image.width={SIZE}", f"image.height={SIZE}"]
    cmd = [str(BIN), "serve", str(scene), "--port", "0"] + [x for s in sets for x in ("--set", s)]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        url = p.stdout.readline().strip()
        addr, token = url[len("http://"):].split("/?token=")
        request(addr, token, "GET", "/api/frame")  # first frame: pipelines, grid upload, bricks
        _, _, info = request(addr, token, "GET", "/api/state")
        iso = json.loads(info)["surface"]["isovalue"]
        rows = []
        for i in range(RUNS):
            changed = sets + [f"surface.isovalue={iso + 1e-4 * (i + 1)}"]
            t0 = time.perf_counter()
            _, _, body = request(addr, token, "POST", "/api/state", {"set": changed, "preview": True})
            g = json.loads(body)["generation"]
            _, h1, _ = request(addr, token, "GET", f"/api/frame?after={g - 1}&level=full")
            t1 = time.perf_counter()
            _, h2, _ = request(addr, token, "GET", f"/api/frame?after={g}&level=coarse")
            t2 = time.perf_counter()
            # A still frame without the preview: full resolution at once.
            still = sets + [f"surface.isovalue={iso - 1e-4 * (i + 1)}"]
            t3 = time.perf_counter()
            request(addr, token, "POST", "/api/state", {"set": still})
            _, h3, _ = request(addr, token, "GET", "/api/frame")
            t4 = time.perf_counter()
            assert h1["x-isoview-level"] == "coarse" and h2["x-isoview-level"] == "full", (h1, h2)
            rows.append(((t1 - t0) * 1e3, float(h1["x-isoview-render-ms"]),
                         (t2 - t0) * 1e3, (t4 - t3) * 1e3, float(h3["x-isoview-render-ms"]),
                         float(h3.get("x-isoview-gpu-ms", "nan"))))
        return [statistics.median(c) for c in zip(*rows)]
    finally:
        p.kill()
        p.wait()


print(f"isoview serve at {SIZE}x{SIZE}, median of {RUNS} changes of the isovalue ({BIN})")
print("| scene | coarse: post to PNG | coarse render | full after preview (incl. 150 ms wait) | still: post to PNG | still render | still GPU |")
print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
for scene in sorted((ROOT / "scenes").glob("*.toml")):
    r = bench(scene)
    print(f"| {scene.name} | " + " | ".join(f"{x:.0f} ms" for x in r) + " |", flush=True)
