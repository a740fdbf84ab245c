"""The physical limit of playback: the renderer's multiply-accumulates per frame against what this
CPU's int8 matrix multiply does per second.

``renderer_macs`` counts the convolutions of a renderer config at a frame size (torch forward
hooks: output elements x input channels per group x kernel area). ``int8_gemm_gmacs`` times an
int8 x int8 -> int32 matrix multiply in onnxruntime (``MatMulInteger``, the op family the int8
renderer runs on) and, where torch has it, ``torch._int_mm`` (a plain GEMM call, no graph). The
renderer's fraction of the limit is its MACs a second while playing over the best GEMM rate.
"""

from __future__ import annotations

import time

import numpy as np

# A square GEMM large enough to reach the peak, and one shaped like the renderer's full-resolution
# convolutions (one row per output pixel at 640 / 2, 16 x 3 x 3 inputs, 16 outputs).
SHAPES = {"square": (2048, 1024, 1024), "conv-shaped": (320 * 320, 144, 16)}


def renderer_macs(config: dict, size: int) -> int:
    """Multiply-accumulates of one forward pass of the renderer ``config`` at ``size`` x ``size``."""
    import torch
    from torch import nn

    from morf.avatar.renderer import RendererConfig, UNetRenderer

    net = UNetRenderer(RendererConfig(**config)).eval()
    total = [0]

    def count(mod, inputs, out):
        k = mod.kernel_size[0] * mod.kernel_size[1]
        total[0] += out.numel() * (mod.in_channels // mod.groups) * k

    hooks = [m.register_forward_hook(count) for m in net.modules() if isinstance(m, nn.Conv2d)]
    with torch.no_grad():
        net(torch.zeros(1, net.cfg.in_channels, size, size))
    for h in hooks:
        h.remove()
    return total[0]


def _timed(fn, seconds: float) -> float:
    fn()  # warm-up
    n, t0 = 0, time.perf_counter()
    while True:
        fn()
        n += 1
        dt = time.perf_counter() - t0
        if dt >= seconds and n >= 3:
            return dt / n


def ort_int8_gemm_gmacs(m: int, k: int, n: int, threads: int, seconds: float = 1.0) -> float:
    """GMAC/s of onnxruntime's MatMulInteger (uint8 x int8 -> int32) at (m, k) x (k, n)."""
    import onnx
    import onnxruntime as ort
    from onnx import TensorProto, helper, numpy_helper

    rng = np.random.default_rng(0)
    b = numpy_helper.from_array(rng.integers(-128, 127, (k, n), dtype=np.int8), "B")
    graph = helper.make_graph([helper.make_node("MatMulInteger", ["A", "B"], ["Y"])], "gemm",
                              [helper.make_tensor_value_info("A", TensorProto.UINT8, [m, k])],
                              [helper.make_tensor_value_info("Y", TensorProto.INT32, [m, n])], [b])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads
    sess = ort.InferenceSession(model.SerializeToString(), opts, providers=["CPUExecutionProvider"])
    a = rng.integers(0, 255, (m, k), dtype=np.uint8)
    onnx.checker.check_model(model)
    return m * k * n / _timed(lambda: sess.run(None, {"A": a}), seconds) / 1e9


def torch_int8_gemm_gmacs(m: int, k: int, n: int, threads: int, seconds: float = 1.0) -> float | None:
    """GMAC/s of ``torch._int_mm`` (int8 x int8 -> int32), or None where this torch lacks it."""
    import torch

    if not hasattr(torch, "_int_mm"):
        return None
    old = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        a = torch.randint(-128, 127, (m, k), dtype=torch.int8)
        b = torch.randint(-128, 127, (k, n), dtype=torch.int8)
        return m * k * n / _timed(lambda: torch._int_mm(a, b), seconds) / 1e9
    except RuntimeError:  # a shape or CPU this build's kernel does not take
        return None
    finally:
        torch.set_num_threads(old)


def compute_limit(config: dict, size: int, renderer_ms: float, threads: int, seconds: float = 1.0) -> dict:
    """The renderer's MACs a frame, the GEMM rates of both libraries on both shapes, and the
    renderer's fraction of the best rate while it runs at ``renderer_ms`` a frame."""
    macs = renderer_macs(config, size)
    rates = {f"{lib}_{name}_gmacs": fn(*shape, threads, seconds)
             for name, shape in SHAPES.items()
             for lib, fn in (("onnxruntime", ort_int8_gemm_gmacs), ("torch", torch_int8_gemm_gmacs))}
    best = max(v for v in rates.values() if v)
    achieved = macs / (renderer_ms / 1e3) / 1e9
    return {"renderer_gmacs_per_frame": macs / 1e9, "renderer_gmacs_achieved": achieved, **rates,
            "best_gemm_gmacs": best, "fraction_of_limit": achieved / best,
            "fps_at_limit": best / (macs / 1e9), "threads": threads}
