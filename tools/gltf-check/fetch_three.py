"""Install the pinned three.js into ``node_modules/three`` without Node: the tarball named by
package-lock.json, fetched from the npm registry and checked against the lock's sha512.

    python tools/gltf-check/fetch_three.py     (what ``npm ci`` would do for this one package)
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
REGISTRY = "https://registry.npmjs.org"


def main() -> int:
    entry = json.loads((HERE / "package-lock.json").read_text())["packages"]["node_modules/three"]
    version, integrity = entry["version"], entry["integrity"]
    target = HERE / "node_modules" / "three"
    installed = target / "package.json"
    if installed.is_file() and json.loads(installed.read_text()).get("version") == version:
        print(f"three {version} already in {target}")
        return 0
    url = f"{REGISTRY}/three/-/three-{version}.tgz"
    with urllib.request.urlopen(url, timeout=120) as r:
        data = r.read()
    algo, _, want = integrity.partition("-")
    if algo != "sha512" or base64.b64encode(hashlib.sha512(data).digest()).decode() != want:
        print(f"{url}: checksum differs from package-lock.json", file=sys.stderr)
        return 1
    tmp = Path(tempfile.mkdtemp(dir=HERE, prefix=".three-"))
    try:
        with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
            tar.extractall(tmp, filter="data")
        target.parent.mkdir(exist_ok=True)
        if target.exists():
            shutil.rmtree(target)
        (tmp / "package").rename(target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"three {version} -> {target} ({len(data) / 1e6:.1f} MB download)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
