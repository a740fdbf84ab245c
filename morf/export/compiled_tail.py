"""The renderer graph's full-resolution tail as one compiled pass: its contract (:class:`TailSpec`,
recorded in the avatar folder's manifest), the pass (:class:`TailShader`, numba loops in
:mod:`morf.export.tail_kernels`) and the same function in numpy (:func:`reference_tail`).

The `cpu` preset's renderer ends in about 35 float ops at full resolution: the half-resolution
head's and the colour fill's 2x upsampling, the fill, the mask's sigmoid, the opaque body, the
premultiplication and the compositing. onnxruntime runs them one at a time, each a pass over the
frame's planes (about 8 ms of a 21 ms graph at 640x640 on two cores). The player runs the graph
only up to the two half-resolution tensors (:mod:`morf.playback.native_tail`), and this pass does
the rest in one loop over the output pixels (about 1.5 ms).

The function, per output pixel, with ``up`` the 2x bilinear upsampling (half-pixel centres, edges
clamped) of a half-resolution tensor:

    head = up(HEAD)                     # 3 residual RGB channels + the mask channel
    fill = up(FILL)                     # colour x weight (3) + weight, the fill's finest pull level
    covered = byte[coverage channel] != zero point
    tex = (byte[0:3] - zero point) * colour_scale
    colour = tex + (0 if covered else fill[:3] / max(fill[3], weight_min))
    mask = sigmoid(head[3] * logit_scale + logit_offset), held at 1 where the coverage shrunk by
           opaque_margin pixels is 1
    image = round(255 * ((head[:3] + colour) * mask + (1 - mask) * background / 255)), clipped to 0-255

The exporter states the two tensors and the constants of the graph it wrote
(:mod:`morf.export.native_tail_spec`), checks this pass against the whole graph on its views and
records the spec in the manifest (``renderer.native_tail``).
"""

from __future__ import annotations

import threading
from dataclasses import asdict, dataclass

import numpy as np

KIND = "half-resolution head + colour fill + opaque body + composite, v1"

_LOCK = threading.Lock()  # numba's thread pool must not be entered from two threads at once


@dataclass(frozen=True)
class HeadStage:
    """The half-resolution head's last layers, when the pass computes them too (int8 graphs):
    ``HEAD = weight @ leaky_relu(up(low) + (skip - skip_zero_point) * skip_scale, alpha) + bias``.

    Fields:
        low: the (1, C, H/4, W/4) float tensor upsampled 2x; skip: the (1, C, H/2, W/2) tensor added
            to it (uint8 with its scale and zero point, or float with 1 and 0); alpha: the
            LeakyReLU slope; weight: (4, C); bias: (4,).
    """

    low: str
    skip: str
    skip_scale: float
    skip_zero_point: int
    alpha: float
    weight: tuple[tuple[float, ...], ...]
    bias: tuple[float, ...]

    @staticmethod
    def from_dict(d: dict) -> "HeadStage":
        return HeadStage(low=str(d["low"]), skip=str(d["skip"]), skip_scale=float(d["skip_scale"]),
                         skip_zero_point=int(d["skip_zero_point"]), alpha=float(d["alpha"]),
                         weight=tuple(tuple(float(v) for v in row) for row in d["weight"]),
                         bias=tuple(float(v) for v in d["bias"]))


@dataclass(frozen=True)
class TailSpec:
    """Where the exporter cut the graph and the tail's constants (see the module docstring).

    Fields:
        head, fill: names of the two half-resolution (1, 4, H/2, W/2) float tensors.
        colour_scale: (3,) texture colour per byte step; zero_point: the raster's zero byte.
        coverage_channel: the byte that tells body from background.
        logit_scale, logit_offset: the mask channel's map to the logit (1 and 0 in fp32 graphs).
        weight_min: the fill weight's floor; opaque_margin: pixels (0: no opaque body).
        check: the exporter's comparison with the whole graph (max difference in levels, share
            of differing pixel channels, views).
        head_stage: the head's last layers computed by the pass too (the graph is then cut at
            ``head_stage.low`` and ``.skip`` instead of ``head``), or None.
    """

    head: str
    fill: str
    colour_scale: tuple[float, float, float]
    zero_point: int
    coverage_channel: int
    logit_scale: float
    logit_offset: float
    weight_min: float
    opaque_margin: int
    check: dict | None = None
    kind: str = KIND
    head_stage: HeadStage | None = None

    @property
    def cut(self) -> tuple[str, ...]:
        """The tensors the graph is cut at, in the order :meth:`TailShader.run` takes them."""
        if self.head_stage is not None:
            return (self.head_stage.low, self.head_stage.skip, self.fill)
        return (self.head, self.fill)

    def to_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_dict(d: dict) -> "TailSpec | None":
        """The spec, or None for a manifest entry this version does not understand."""
        if not isinstance(d, dict) or d.get("kind") != KIND:
            return None
        try:
            return TailSpec(head=str(d["head"]), fill=str(d["fill"]),
                            colour_scale=tuple(float(v) for v in d["colour_scale"]),
                            zero_point=int(d["zero_point"]), coverage_channel=int(d["coverage_channel"]),
                            logit_scale=float(d["logit_scale"]), logit_offset=float(d["logit_offset"]),
                            weight_min=float(d["weight_min"]), opaque_margin=int(d["opaque_margin"]),
                            check=d.get("check"),
                            head_stage=HeadStage.from_dict(d["head_stage"]) if d.get("head_stage") else None)
        except (KeyError, TypeError, ValueError):
            return None


class TailShader:
    """The compiled tail on (raster, HEAD, FILL) -> (H, W, 3) uint8, with its buffers."""

    def __init__(self, spec: TailSpec, threads: int = 2):
        from morf.export import tail_kernels

        self.spec = spec
        self.threads = max(1, int(threads))
        self._k = tail_kernels
        self._table = tail_kernels.sigmoid_table()
        self._scale = np.asarray(spec.colour_scale, np.float32)
        self._rows = np.empty((0, 0), np.uint8)
        self._out = np.empty((0, 0, 3), np.uint8)
        stage = spec.head_stage
        self._weight = None if stage is None else np.asarray(stage.weight, np.float32)
        self._bias = None if stage is None else np.asarray(stage.bias, np.float32)

    def __call__(self, raster: np.ndarray, head: np.ndarray, fill: np.ndarray, background: np.ndarray,
                 out: np.ndarray | None = None) -> np.ndarray:
        """raster: (1, H, W, 16) uint8; head, fill: (1, 4, H/2, W/2) float32; background: the
        graph's (1, 3, 1|H, 1|W) float32 planes, 0-255. Returns ``out`` or a reused buffer."""
        import numba

        s, k = self.spec, self._k
        H, W = raster.shape[1:3]
        if head.shape[2] * 2 != H or head.shape[3] * 2 != W or fill.shape != head.shape:
            raise ValueError(f"half-resolution tensors {head.shape} / {fill.shape} do not match a {H}x{W} raster")
        if out is None:
            if self._out.shape != (H, W, 3):
                self._out = np.empty((H, W, 3), np.uint8)
            out = self._out
        if self._rows.shape != (H, W):
            self._rows = np.empty((H, W), np.uint8)
        bg = np.ascontiguousarray(background[0], np.float32)
        with _LOCK:
            numba.set_num_threads(min(self.threads, numba.config.NUMBA_NUM_THREADS))
            if s.opaque_margin > 0:
                k.erode_rows(raster, s.coverage_channel, s.zero_point, s.opaque_margin, self._rows)
            k.shade(raster, head, fill, self._scale, s.zero_point, s.coverage_channel, np.float32(s.logit_scale),
                    np.float32(s.logit_offset), np.float32(s.weight_min), s.opaque_margin, self._rows, bg,
                    self._table, out)
        return out

    def head(self, low: np.ndarray, skip: np.ndarray) -> np.ndarray:
        """HEAD from the head stage's two tensors (:class:`HeadStage`): (1, 4, 2h, 2w) float32."""
        import numba

        st = self.spec.head_stage
        if st is None:
            raise ValueError("this tail has no head stage")
        if skip.shape[2] != 2 * low.shape[2] or skip.shape[3] != 2 * low.shape[3] or skip.shape[1] != low.shape[1]:
            raise ValueError(f"head tensors {low.shape} / {skip.shape} do not match")
        if self._weight.shape[1] != low.shape[1]:  # the compiled loop does not check bounds
            raise ValueError(f"head weights take {self._weight.shape[1]} channels, the graph gives {low.shape[1]}")
        out = np.empty((1, self._weight.shape[0], *skip.shape[2:]), np.float32)
        with _LOCK:
            numba.set_num_threads(min(self.threads, numba.config.NUMBA_NUM_THREADS))
            self._k.head_stage(low, skip, np.float32(st.skip_scale), st.skip_zero_point, np.float32(st.alpha),
                               self._weight, self._bias, out)
        return out

    def run(self, cut: list[np.ndarray], raster: np.ndarray, background: np.ndarray,
            out: np.ndarray | None = None) -> np.ndarray:
        """The image from the cut graph's outputs (in the order of :attr:`TailSpec.cut`)."""
        if self.spec.head_stage is not None:
            low, skip, fill = cut
            return self(raster, self.head(low, skip), fill, background, out=out)
        head, fill = cut
        return self(raster, head, fill, background, out=out)


def up_bilinear_2x(t: np.ndarray) -> np.ndarray:
    """(C, h, w) -> (C, 2h, 2w) bilinear, half-pixel centres, clamped edges (float64)."""
    h, w = t.shape[1:]

    def taps(n_out, n_in):
        s = np.clip((np.arange(n_out) + 0.5) / 2 - 0.5, 0, n_in - 1)
        a = np.floor(s).astype(int)
        return a, np.minimum(a + 1, n_in - 1), s - a

    ya, yb, fy = taps(2 * h, h)
    xa, xb, fx = taps(2 * w, w)
    rows = t[:, ya] * (1 - fy)[None, :, None] + t[:, yb] * fy[None, :, None]
    return rows[:, :, xa] * (1 - fx) + rows[:, :, xb] * fx


def reference_head(stage: HeadStage, low: np.ndarray, skip: np.ndarray) -> np.ndarray:
    """:meth:`TailShader.head` in plain numpy (float64)."""
    h = up_bilinear_2x(low[0].astype(np.float64)) + (skip[0].astype(np.float64) - stage.skip_zero_point) * stage.skip_scale
    h = np.where(h < 0, h * stage.alpha, h)
    out = np.einsum("kc,chw->khw", np.asarray(stage.weight), h) + np.asarray(stage.bias)[:, None, None]
    return out[None].astype(np.float32)


def reference_tail(spec: TailSpec, raster: np.ndarray, head: np.ndarray, fill: np.ndarray,
                   background: np.ndarray) -> np.ndarray:
    """The same function in plain numpy (float64, slow): what tests hold the compiled pass to."""
    import scipy.ndimage as ndi

    b = raster[0].astype(np.float64)
    hd, fl = up_bilinear_2x(head[0].astype(np.float64)), up_bilinear_2x(fill[0].astype(np.float64))
    covered = raster[0, :, :, spec.coverage_channel] != spec.zero_point
    tex = (b[:, :, :3] - spec.zero_point) * np.asarray(spec.colour_scale)
    colour = tex + np.where(covered, 0.0, 1.0)[..., None] * (fl[:3] / np.maximum(fl[3], spec.weight_min)).transpose(1, 2, 0)
    mask = 1.0 / (1.0 + np.exp(-(hd[3] * spec.logit_scale + spec.logit_offset)))
    if spec.opaque_margin > 0:
        m = spec.opaque_margin
        inside = ndi.minimum_filter(covered.astype(np.uint8), size=2 * m + 1, mode="nearest").astype(bool)
        # the graph's MaxPool pads with -inf: the window is clipped to the image, which "nearest" matches for a minimum
        mask = np.maximum(mask, inside)
    bg = np.broadcast_to(background[0].transpose(1, 2, 0), (*covered.shape, 3)) / 255.0
    col = (hd[:3].transpose(1, 2, 0) + colour) * mask[..., None] + (1 - mask[..., None]) * bg
    return np.clip(np.rint(col * 255.0), 0, 255).astype(np.uint8)
