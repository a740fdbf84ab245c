"""Install the pinned three.js into ``node_modules/three`` without Node: the tarball named by
package-lock.json, fetched from the npm registry and checked against the lock's sha512
(:func:`morf.web.npm.install_locked`).

    python tools/gltf-check/fetch_three.py     (what ``npm ci`` would do for this one package)
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the checkout's morf, for any python 3.11
from morf.web.npm import install_locked  # noqa: E402 (after the path)

if __name__ == "__main__":
    sys.exit(install_locked(Path(__file__).resolve().parent, "three"))
