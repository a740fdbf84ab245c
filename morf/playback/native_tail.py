"""The player's renderer with the graph's full-resolution tail as one compiled pass
(:mod:`morf.export.compiled_tail`): onnxruntime runs the graph cut at the tail's two
half-resolution tensors, the pass does the rest. The player uses it when the avatar folder's
manifest has the tail's spec (``renderer.native_tail``), numba imports and ``MORF_NATIVE_TAIL`` is
not ``0``; otherwise it runs the whole graph.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from morf.export.compiled_tail import TailShader, TailSpec

ENV = "MORF_NATIVE_TAIL"


def enabled() -> bool:
    """Whether the player may use the native tail (``MORF_NATIVE_TAIL=0`` turns it off)."""
    from morf.machine.compiled import numba_available  # the machine probes load only when asked

    return os.environ.get(ENV, "1") != "0" and numba_available()


def spec_for(manifest: dict, precision: str) -> TailSpec | None:
    """The manifest's tail spec for ``precision`` ("int8" / "fp32"), or None."""
    renderer = manifest.get("renderer") or {}
    if renderer.get("input_layout") != "nhwc":
        return None
    return TailSpec.from_dict((renderer.get("native_tail") or {}).get(precision))


class TailRenderer:
    """The renderer graph cut where the tail starts (onnxruntime) + :class:`TailShader`.

    Offers what the player uses of :class:`morf.playback.onnx_renderer.OnnxRenderer`:
    ``input_name``, ``composites`` (False: the cut graph does not composite, the pass does),
    :meth:`image`, and ``graph`` (the cut graph's bytes, for the profiler). The timings of the last
    :meth:`image` are in ``last_timings``.
    """

    composites = False

    def __init__(self, path: str | Path, spec: TailSpec, threads: int = 2, spinning: bool = False,
                 size: int | None = None):
        import onnxruntime as ort

        from morf.errors import InputError
        from morf.playback.graph_outputs import cut_graph
        from morf.playback.onnx_renderer import session_options

        self.path, self.spec = Path(path), spec
        try:
            self.graph = cut_graph(self.path.read_bytes(), spec.cut)
            self.session = ort.InferenceSession(self.graph, session_options(threads, spinning, size),
                                                providers=["CPUExecutionProvider"])
        except Exception as e:  # unreadable file, or names the graph does not have
            raise InputError(f"cannot load renderer {path} with its native tail: {e}") from None
        self.input_name = self.session.get_inputs()[0].name
        self.shader = TailShader(spec, threads)
        self.last_timings: dict[str, float] = {}

    def image(self, raster: np.ndarray, background: np.ndarray) -> np.ndarray:
        """raster (1, H, W, 16) uint8 -> (H, W, 3) uint8 composited over ``background`` planes."""
        t0 = time.perf_counter()
        cut = self.session.run(list(self.spec.cut), {self.input_name: raster})
        t1 = time.perf_counter()
        img = self.shader.run(cut, raster, background, out=np.empty((*raster.shape[1:3], 3), np.uint8))
        self.last_timings = {"graph_ms": (t1 - t0) * 1e3, "tail_ms": (time.perf_counter() - t1) * 1e3}
        return img
