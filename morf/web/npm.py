"""One package from the npm registry without Node, as ``npm ci`` would install it: the tarball the
folder's package-lock.json names, fetched once, checked against the lock's sha512 and unpacked into
``node_modules/NAME``. The browser tools use it for their pinned libraries (onnxruntime-web for the
web player, three.js for the glTF check); nothing at run time needs the network.
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

REGISTRY = "https://registry.npmjs.org"


def install_locked(folder: Path, package: str, keep: tuple[str, ...] | None = None, timeout: float = 300.0,
                   lock: Path | None = None) -> int:
    """Install ``package`` at the version ``lock`` (default ``folder/package-lock.json``) pins into
    ``folder/node_modules/package``; ``keep``: the only paths inside the package to unpack (e.g.
    ``dist/x.mjs``; ``package.json`` always), or None for all. Already installed (same version,
    every kept file present): nothing is fetched. Returns 0, or 1 with the reason on stderr."""
    entry = json.loads((lock or folder / "package-lock.json").read_text())["packages"][f"node_modules/{package}"]
    version, integrity = entry["version"], entry["integrity"]
    url = entry.get("resolved") or f"{REGISTRY}/{package}/-/{package.rsplit('/', 1)[-1]}-{version}.tgz"
    target = folder / "node_modules" / package
    wanted = None if keep is None else ("package.json", *keep)
    installed = target / "package.json"
    if installed.is_file() and json.loads(installed.read_text()).get("version") == version \
            and all((target / name).is_file() for name in wanted or ()):
        print(f"{package} {version} already in {target}")
        return 0
    with urllib.request.urlopen(url, timeout=timeout) as r:
        data = r.read()
    algo, _, want = integrity.partition("-")
    if algo != "sha512" or base64.b64encode(hashlib.sha512(data).digest()).decode() != want:
        print(f"{url}: checksum differs from package-lock.json", file=sys.stderr)
        return 1
    folder.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=folder, prefix=f".{package}-"))
    try:
        with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
            members = tar.getmembers()
            if wanted is not None:
                names = {f"package/{name}" for name in wanted}
                members = [m for m in members if m.name in names]
                missing = names - {m.name for m in members}
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
    print(f"{package} {version} -> {target} ({len(data) / 1e6:.1f} MB download)")
    return 0
