"""Install the pinned onnxruntime-web into the user's cache without Node (what ``morf web
--fetch-libs`` does): the tarball resources/web-libs/package-lock.json names, fetched from the npm
registry once and checked against the lock's sha512 (:func:`morf.web.libraries.fetch_libraries`).
Only the prebuilt files the browser player copies are unpacked; ``morf web`` and ``morf export
--web`` read them from there.

    python tools/web-player/fetch_ort.py     (what ``npm ci`` would do for this one package)
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the checkout's morf, for any python 3.11
from morf.web.libraries import fetch_libraries  # noqa: E402 (after the path)

if __name__ == "__main__":
    sys.exit(fetch_libraries())
