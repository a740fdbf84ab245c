"""Install the pinned onnxruntime-web into ``node_modules/onnxruntime-web`` without Node: the tarball
named by package-lock.json, fetched from the npm registry once and checked against the lock's
sha512 (:func:`morf.web.npm.install_locked`). Only the prebuilt files the browser player copies are
unpacked (``dist/`` below and the package.json); ``morf web`` and ``morf export --web`` read them from here.

    python tools/web-player/fetch_ort.py     (what ``npm ci`` would do for this one package)
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the checkout's morf, for any python 3.11
from morf.web.npm import install_locked  # noqa: E402 (after the path)

HERE = Path(__file__).resolve().parent
# The browser player's files: the WASM build (SIMD + threads) and the WebGPU build (asyncify).
DIST = ("ort.wasm.min.mjs", "ort-wasm-simd-threaded.mjs", "ort-wasm-simd-threaded.wasm",
        "ort.webgpu.min.mjs", "ort-wasm-simd-threaded.asyncify.mjs", "ort-wasm-simd-threaded.asyncify.wasm")

if __name__ == "__main__":
    sys.exit(install_locked(HERE, "onnxruntime-web", tuple(f"dist/{name}" for name in DIST)))
