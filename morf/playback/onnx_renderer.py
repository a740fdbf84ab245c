"""The exported renderer run by onnxruntime (torch-free)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def session_options(threads: int = 2, spinning: bool = False):
    """ORT options for playback: ``threads`` intra-op threads; no spinning (idle cores stay idle
    between frames, which costs almost no latency and matters inside an interactive app)."""
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads
    opts.inter_op_num_threads = 1
    opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    opts.add_session_config_entry("session.intra_op.allow_spinning", "1" if spinning else "0")
    return opts


class OnnxRenderer:
    """uint8 neural rasterization -> (H, W, 4) float32 premultiplied RGB + mask probability."""

    def __init__(self, path: str | Path, threads: int = 2, spinning: bool = False):
        import onnxruntime as ort

        from morf.errors import InputError

        try:
            self.session = ort.InferenceSession(str(path), session_options(threads, spinning),
                                                providers=["CPUExecutionProvider"])
        except Exception as e:  # onnxruntime raises its own exception types for bad files
            raise InputError(f"cannot load renderer {path}: {e}") from None
        self.input_name = self.session.get_inputs()[0].name

    def __call__(self, raster: np.ndarray) -> np.ndarray:
        """raster: uint8 in the graph's layout -> (1, 4, H, W) float32."""
        return self.session.run(None, {self.input_name: raster})[0]
