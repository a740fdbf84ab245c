"""The exported renderer run by onnxruntime (torch-free)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def session_options(threads: int = 2, spinning: bool = False, size: int | None = None):
    """ORT options for playback: ``threads`` intra-op threads; no spinning (idle cores stay idle
    between frames, which costs almost no latency and matters inside an interactive app).

    ``size``: the side of every image the session will see. The exported graphs name their image
    dimensions ``height`` and ``width``; fixed, onnxruntime folds the shape arithmetic of the
    resizes into constants (0.2 ms of a 10.3 ms cut graph at 640 x 640 on a 2-core Intel Xeon)."""
    import onnxruntime as ort

    opts = ort.SessionOptions()
    if size is not None:
        for dim in ("height", "width"):
            opts.add_free_dimension_override_by_name(dim, int(size))
    opts.intra_op_num_threads = threads
    opts.inter_op_num_threads = 1
    opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    opts.add_session_config_entry("session.intra_op.allow_spinning", "1" if spinning else "0")
    return opts


def image_only_graph(path: str | Path) -> bytes | None:
    """The serialized graph at ``path`` with ``image`` as its only output and the nodes that fed
    only ``rgba`` removed (:func:`morf.playback.graph_outputs.keep_outputs`), or None when the
    graph does not composite.

    onnxruntime runs every node of a session's graph whatever a run fetches, so a session that
    only ever fetches ``image`` would still concatenate the float ``rgba`` planes (0.25 ms at
    640x640, 1.3 % of the graph, measured on a 2-core Intel Xeon with AMX).
    """
    from morf.playback.graph_outputs import keep_outputs

    return keep_outputs(Path(path).read_bytes(), ("image",))


class OnnxRenderer:
    """uint8 neural rasterization -> premultiplied RGB + mask, or the composited image.

    Graphs exported since compositing moved into the graph have a ``background`` input and an
    ``image`` output (:func:`morf.export.onnx_graph.append_composite`); for older ones
    :meth:`image` composites in numpy. Playback fetches only ``image``: its session runs the
    graph without the ``rgba`` output (:func:`image_only_graph`), and a second session for
    ``rgba`` opens on the first call that asks for it.
    """

    def __init__(self, path: str | Path, threads: int = 2, spinning: bool = False, size: int | None = None):
        self.path = Path(path)
        self._options = (threads, spinning, size)
        try:
            lean = image_only_graph(self.path)
        except (OSError, ValueError) as e:  # unreadable, or not a serialized model
            from morf.errors import InputError

            raise InputError(f"cannot load renderer {path}: {e}") from None
        self.session = self._open(lean if lean is not None else str(self.path))
        inputs = [i.name for i in self.session.get_inputs()]
        self.input_name = inputs[0]
        self.composites = "background" in inputs and any(o.name == "image" for o in self.session.get_outputs())
        self._rgba_session = None if lean is not None else self.session
        self._black = np.zeros((1, 3, 1, 1), np.float32)

    def _open(self, model):
        import onnxruntime as ort

        from morf.errors import InputError

        try:
            return ort.InferenceSession(model, session_options(*self._options), providers=["CPUExecutionProvider"])
        except Exception as e:  # onnxruntime raises its own exception types for bad files
            raise InputError(f"cannot load renderer {self.path}: {e}") from None

    def __call__(self, raster: np.ndarray) -> np.ndarray:
        """raster: uint8 in the graph's layout -> (1, 4, H, W) float32 premultiplied RGB + mask."""
        if self._rgba_session is None:
            self._rgba_session = self._open(str(self.path))
        feed = {self.input_name: raster}
        if self.composites:
            feed["background"] = self._black
        return self._rgba_session.run(["rgba"], feed)[0]

    def image(self, raster: np.ndarray, background: np.ndarray) -> np.ndarray:
        """raster -> (H, W, 3) uint8 composited over ``background`` (see :func:`background_planes`)."""
        if not self.composites:
            from morf.playback.composite import composite

            return composite(self(raster), background[0].transpose(1, 2, 0))
        return self.session.run(["image"], {self.input_name: raster, "background": background})[0][0]


def background_planes(background, size: int) -> np.ndarray:
    """An RGB colour triple or an (H, W, 3) image (0-255) -> the graph's float32 ``background``:
    (1, 3, 1, 1) for a colour, (1, 3, H, W) for an image (which must be size x size)."""
    bg = np.asarray(background, np.float32)
    if bg.shape == (3,):
        return bg.reshape(1, 3, 1, 1).copy()
    if bg.shape != (size, size, 3):
        raise ValueError(f"background must be an RGB triple or a ({size}, {size}, 3) image, got {bg.shape}")
    return np.ascontiguousarray(bg.transpose(2, 0, 1)[None])
