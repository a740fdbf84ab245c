"""Install the pinned onnxruntime-web into ``node_modules/onnxruntime-web`` without Node: the tarball
named by package-lock.json, fetched from the npm registry once and checked against the lock's
sha512. Only the prebuilt files the browser player copies are unpacked (``dist/`` below, the
package.json and the licence); ``morf web`` and ``morf export --web`` read them from here.

    python tools/web-player/fetch_ort.py     (what ``npm ci`` would do for this one package)
"""

from __future__ import annotations

import base64
import hashlib
import io
import json
import shutil
import sys
import tarfile
import tempfile
import urllib.request
from pathlib import Path

HERE = Path(__file__).resolve().parent
PACKAGE = "onnxruntime-web"
# The browser player's files: the WASM build (SIMD + threads) and the WebGPU build (asyncify).
DIST = ("ort.wasm.min.mjs", "ort-wasm-simd-threaded.mjs", "ort-wasm-simd-threaded.wasm",
        "ort.webgpu.min.mjs", "ort-wasm-simd-threaded.asyncify.mjs", "ort-wasm-simd-threaded.asyncify.wasm")
KEEP = ("package/package.json", *(f"package/dist/{name}" for name in DIST))


def main() -> int:
    entry = json.loads((HERE / "package-lock.json").read_text())["packages"][f"node_modules/{PACKAGE}"]
    version, integrity, url = entry["version"], entry["integrity"], entry["resolved"]
    target = HERE / "node_modules" / PACKAGE
    installed = target / "package.json"
    if installed.is_file() and json.loads(installed.read_text()).get("version") == version \
            and all((target / "dist" / name).is_file() for name in DIST):
        print(f"{PACKAGE} {version} already in {target}")
        return 0
    with urllib.request.urlopen(url, timeout=300) as r:
        data = r.read()
    algo, _, want = integrity.partition("-")
    if algo != "sha512" or base64.b64encode(hashlib.sha512(data).digest()).decode() != want:
        print(f"{url}: checksum differs from package-lock.json", file=sys.stderr)
        return 1
    tmp = Path(tempfile.mkdtemp(dir=HERE, prefix=".ort-"))
    try:
        with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
            members = [m for m in tar.getmembers() if m.name in KEEP]
            missing = set(KEEP) - {m.name for m in members}
            if missing:
                print(f"{url}: the package lacks {', '.join(sorted(missing))}", file=sys.stderr)
                return 1
            tar.extractall(tmp, members=members, filter="data")
        target.parent.mkdir(exist_ok=True)
        if target.exists():
            shutil.rmtree(target)
        (tmp / "package").rename(target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{PACKAGE} {version} -> {target} ({len(data) / 1e6:.1f} MB download)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
