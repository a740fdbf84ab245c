"""Load a .glb in three.js (GLTFLoader) inside headless Chromium and report what it read.

    python tools/gltf-check/gltf_in_browser.py AVATAR.glb OUT_DIR [--times 0,0.1] [--pose POSE.json]

(``scripts/gltf_in_browser.sh`` runs this.) A local HTTP server on 127.0.0.1 serves this folder
(``check.html``, ``check.js``, ``node_modules/three``), the .glb as ``/avatar.glb`` and the pose as
``/pose.json``; Chromium opens the page with WebGL on SwiftShader (software, no GPU needed), and
the page posts its findings back to ``/result``. OUT_DIR then holds:

    report.json      what three.js read (meshes, vertices, joints, animations, texture size, WebGL
                     renderer), each pose's skinned bounding box and a few skinned vertices, the
                     checks below
    positions.npz    rest (V, 3); cpu, gpu (P, V, 3) float32 world positions of every vertex after
                     skinning, per pose: three's SkinnedMesh.getVertexPosition (cpu) and its skinning
                     shader chunks on the GPU (gpu); names (P,), times (P,) (NaN: not an animation time)
    screenshot.png   one panel per pose, left to right as in report.json
    chromium.log     the browser's own output

Exits 0 when every check passes, 1 when one fails, 2 when the tools are missing. The checks need
nothing but the file: the bind pose leaves the mesh where it is, the GPU skins as the CPU does,
every position is finite, and every panel shows a body (pixels off the background colour). How
close the skin comes to MoRF's own skinning is tests/export/test_gltf_browser.py's business.

Needs: three (pinned in package-lock.json: ``python fetch_three.py`` here, or ``npm ci``), and Chromium (Debian:
``apt-get install chromium-headless-shell``, or ``chromium``; ``--chromium`` or $CHROMIUM name
another binary). Node is not needed.
"""

from __future__ import annotations

import argparse
import base64
import io
import json
import subprocess
import sys
import threading
import time
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np

# the web player's Chromium driver (morf is installed in the virtualenv this script runs with)
from morf.web.browser import BROWSERS, browse_until, find_chromium

HERE = Path(__file__).resolve().parent
THREE_MODULE = HERE / "node_modules" / "three" / "build" / "three.module.js"
# WebGL on SwiftShader through ANGLE: the software path, the same on every machine.
BROWSER_FLAGS = ("--headless", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                 "--ignore-gpu-blocklist", "--disable-dev-shm-usage", "--no-first-run", "--mute-audio",
                 "--disable-extensions", "--hide-scrollbars")

# Checks, as a share of the bind pose's height (a body: 1 mm in 1.7 m is about 6e-4).
BIND_TOL = 1e-4  # the bind pose must leave the mesh where it is (float32 rounding only)
GPU_TOL = 1e-4  # the skinning shader against three's CPU skinning of the same pose
MIN_BODY_SHARE = 0.02  # share of a panel's pixels off the background for "a body is drawn"


def missing_tools(chromium: str | None = None) -> str | None:
    """Why the check cannot run here (a sentence), or None when it can."""
    if find_chromium(chromium) is None:
        return (f"no Chromium ({' / '.join(BROWSERS)} on PATH, or $CHROMIUM); "
                "Debian: apt-get install chromium-headless-shell")
    if not THREE_MODULE.is_file():
        return f"three.js is not installed: run `python {HERE}/fetch_three.py` (or `npm ci` there)"
    return None


class _Server(ThreadingHTTPServer):
    daemon_threads = True

    def __init__(self, glb: Path, pose: Path | None):
        self.files = {"/avatar.glb": glb, **({"/pose.json": pose} if pose else {})}
        self.result: dict | None = None
        self.done = threading.Event()
        super().__init__(("127.0.0.1", 0), _Handler)


class _Handler(SimpleHTTPRequestHandler):
    extensions_map = {**SimpleHTTPRequestHandler.extensions_map, ".js": "text/javascript",
                      ".glb": "model/gltf-binary", ".json": "application/json"}

    def __init__(self, *args, **kwargs):
        super().__init__(*args, directory=str(HERE), **kwargs)

    def translate_path(self, path: str) -> str:
        mapped = self.server.files.get(path.split("?", 1)[0])
        return str(mapped) if mapped else super().translate_path(path)

    def do_POST(self) -> None:  # noqa: N802 (http.server's naming)
        body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
        self.send_response(204)
        self.end_headers()
        if self.path == "/result":
            self.server.result = json.loads(body)
            self.server.done.set()

    def log_message(self, *args) -> None:
        pass


def run_page(glb: Path, out_dir: Path, times: str | None = None, pose: Path | None = None,
             panel: str = "240x400", chromium: str | None = None, timeout: float = 300.0) -> dict:
    """Open the page on ``glb`` in headless Chromium; returns what it posted (raises on a timeout)."""
    server = _Server(glb, pose)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    query = f"panel={panel}" + (f"&times={times}" if times else "") + ("&pose=1" if pose else "")
    url = f"http://127.0.0.1:{server.server_address[1]}/check.html?{query}"
    try:
        browse_until(url, server.done, timeout, chromium, out_dir / "chromium.log", BROWSER_FLAGS)
    finally:
        server.shutdown()
        server.server_close()
    return server.result


def floats(b64: str, n: int) -> np.ndarray:
    """A base64 float32 array from the page -> (n, 3)."""
    return np.frombuffer(base64.b64decode(b64), np.float32).reshape(n, 3)


def panel_body_shares(png: bytes, count: int, background) -> list[float]:
    """Share of each panel's pixels farther than 8/255 from the background colour, left to right."""
    from PIL import Image

    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.int16)
    off = np.abs(rgb - np.asarray(background, np.int16)).max(-1) > 8
    return [float(p.mean()) for p in np.array_split(off, count, axis=1)]


def write_results(page: dict, out_dir: Path) -> dict:
    """Write positions.npz, screenshot.png and report.json from the page's post; returns the report."""
    V = page["vertices"]
    poses = page.pop("poses")
    rest = floats(page.pop("rest"), V)
    cpu = np.stack([floats(p.pop("cpu"), V) for p in poses])
    gpu = np.stack([floats(p.pop("gpu"), V) for p in poses])
    names = np.array([p["name"] for p in poses])
    times = np.array([np.nan if p["time"] is None else p["time"] for p in poses])
    np.savez(out_dir / "positions.npz", rest=rest, cpu=cpu, gpu=gpu, names=names, times=times)
    png = base64.b64decode(page.pop("screenshot").split(",", 1)[1])
    (out_dir / "screenshot.png").write_bytes(png)

    height = float(rest[:, 1].max() - rest[:, 1].min())
    shares = panel_body_shares(png, len(poses), page["background"])
    sample = np.linspace(0, V - 1, 5).astype(int)
    for p, c, g, share in zip(poses, cpu, gpu, shares):
        p["gpu_vs_cpu_max_m"] = float(np.abs(g.astype(np.float64) - c).max())
        p["body_pixel_share"] = round(share, 4)
        p["sample_vertices"] = {int(i): [round(float(x), 6) for x in c[i]] for i in sample}
    bind_drift = float(np.abs(cpu[0].astype(np.float64) - rest).max())
    checks = {
        "skinned mesh read": page["skinned_meshes"] >= 1 and page["joints"] >= 1 and V > 0,
        "positions finite": bool(np.isfinite(cpu).all() and np.isfinite(gpu).all()),
        "bind pose leaves the mesh in place": bind_drift <= BIND_TOL * height,
        "GPU skinning = CPU skinning": all(p["gpu_missing"] == 0 and p["gpu_vs_cpu_max_m"] <= GPU_TOL * height
                                           for p in poses),
        "a body in every panel": min(shares) >= MIN_BODY_SHARE,
    }
    report = {**page, "height_m": height, "bind_pose_drift_m": bind_drift, "poses": poses,
              "checks": checks, "passed": all(checks.values())}
    (out_dir / "report.json").write_text(json.dumps(report, indent=1))
    return report


def chromium_version(browser: str) -> str:
    try:
        return subprocess.run([browser, "--version"], capture_output=True, text=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("glb", type=Path)
    ap.add_argument("out_dir", type=Path)
    ap.add_argument("--times", help="animation times in seconds, comma-separated (default: 4 across the first)")
    ap.add_argument("--pose", type=Path, help='a JSON pose: {"name", "rotations": (J, 4) xyzw, "translations": (J, 3)}')
    ap.add_argument("--panel", default="240x400", help="pixels per pose panel, WxH")
    ap.add_argument("--chromium", help="the Chromium binary (default: $CHROMIUM or the first on PATH)")
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds to wait for the page")
    args = ap.parse_args(argv)
    why = missing_tools(args.chromium)
    if why:
        print(f"gltf_in_browser: {why}", file=sys.stderr)
        return 2
    if not args.glb.is_file():
        print(f"gltf_in_browser: no such file: {args.glb}", file=sys.stderr)
        return 2
    args.out_dir.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    page = run_page(args.glb.resolve(), args.out_dir, args.times, args.pose, args.panel, args.chromium, args.timeout)
    if "error" in page:
        (args.out_dir / "report.json").write_text(json.dumps({**page, "passed": False}, indent=1))
        print(f"gltf_in_browser: the page failed:\n{page['error']}", file=sys.stderr)
        return 1
    page["chromium"] = chromium_version(find_chromium(args.chromium))
    page["seconds"] = round(time.monotonic() - started, 1)
    report = write_results(page, args.out_dir)
    anims = ", ".join(f"{a['name']} {a['duration']:.3f} s" for a in report["animations"]) or "none"
    tex = f"{report['texture']['width']}x{report['texture']['height']}" if report["texture"] else "none"
    print(f"three r{report['three']} in {report['chromium']} ({report['webgl']['renderer']}), {page['seconds']} s")
    print(f"meshes {report['meshes']} (skinned {report['skinned_meshes']}), vertices {report['vertices']}, "
          f"joints {report['joints']}, animations: {anims}, texture {tex}")
    for p in report["poses"]:
        print(f"  {p['name']:<16} GPU vs CPU {p['gpu_vs_cpu_max_m'] * 1e3:.4f} mm, "
              f"body pixels {p['body_pixel_share']:.3f}")
    for name, ok in report["checks"].items():
        print(f"  [{'ok' if ok else 'FAILED'}] {name}")
    print(f"wrote {args.out_dir / 'report.json'}, positions.npz, screenshot.png")
    return 0 if report["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
