"""Frames of a web folder rendered by the page in headless Chromium, for given poses and cameras
(harness.js ``?check=1``): what the tests hold against the Python player's frames."""

from __future__ import annotations

import base64
import json
import tempfile
from pathlib import Path

import numpy as np

from morf.web.browser import run_page


def camera_json(camera) -> dict:
    """A :class:`morf.camera.PinholeCamera` as the page reads it (R row-major)."""
    return {"fx": float(camera.fx), "fy": float(camera.fy), "cx": float(camera.cx), "cy": float(camera.cy),
            "width": int(camera.width), "height": int(camera.height),
            "R": [float(v) for v in np.asarray(camera.R).reshape(-1)], "t": [float(v) for v in np.asarray(camera.t)]}


def page_frames(folder: str | Path, frames: list[tuple[np.ndarray, np.ndarray, object]], background=(255, 255, 255),
                timeout: float = 180.0, isolation: bool = True, query: str = "",
                rasters: bool = False, webgpu: bool = False, outputs: bool = False) -> tuple[list[np.ndarray], dict]:
    """The page's images of (rotvecs (J, 3), transl (3,), camera) frames, each (H, W, 3) uint8 at its
    camera's size, and the rest of what the page posted (environment, console messages). ``query``:
    more of the page's parameters (``tail=js``). ``rasters``: also the renderer input the page read
    back for each frame, as ``info["rasters"]`` ((H, W, 16) uint8 each; the renderer then runs on
    the whole frame, not the person's window). ``info["windows"]``: the window each frame's renderer
    ran on ({x, y, w, h}). ``webgpu``: offer the page WebGPU (the query's ``backend=webgpu`` picks it).
    ``outputs`` (with ``rasters``): also the renderer's outputs as the tail got them, the colour fill the
    page computed included, as ``info["outputs"]`` ({name: float32 array} per frame)."""
    request = {"background": [float(v) for v in background], "raster": rasters, "outputs": outputs, "frames": [
        {"pose": [float(v) for v in np.concatenate([np.asarray(r, np.float64).reshape(-1), np.asarray(t, np.float64)])],
         "camera": camera_json(c), "size": int(c.width)} for r, t, c in frames]}
    with tempfile.TemporaryDirectory(prefix="morf-web-check-") as tmp:
        path = Path(tmp) / "check.json"
        path.write_text(json.dumps(request))
        result = run_page(folder, "check=1" + (f"&{query}" if query else ""), extra={"/check.json": path}, timeout=timeout,
                          isolation=isolation, webgpu=webgpu)
    if "error" in result:
        raise RuntimeError(f"the page failed: {result['error']}")
    images, result["rasters"], result["outputs"] = [], [], []
    result["windows"] = [item.get("window") for item in result["images"]]
    for item in result.pop("images"):
        s = item["size"]
        images.append(np.frombuffer(base64.b64decode(item["rgba"]), np.uint8).reshape(s, s, 4)[..., :3].copy())
        if rasters:
            result["rasters"].append(np.frombuffer(base64.b64decode(item["raster"]), np.uint8).reshape(s, s, 16).copy())
        if outputs and "outputs" in item:
            result["outputs"].append({k: np.frombuffer(base64.b64decode(t["data"]), np.float32).reshape(t["dims"]).copy()
                                      for k, t in item["outputs"].items() if t["type"] == "float32"})
    return images, result


def psnr(a: np.ndarray, b: np.ndarray, where: np.ndarray | None = None) -> float:
    """PSNR in dB of two uint8 images over the pixels ``where`` (H, W) bool (all when None)."""
    d = (a.astype(np.float64) - b.astype(np.float64)) ** 2
    d = d[where] if where is not None else d
    mse = float(d.mean()) if d.size else 0.0
    return float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)
