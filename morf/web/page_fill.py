"""The colour fill's push-pull pyramid computed by the page instead of the renderer graph.

The tail graph's second output (FILL, :mod:`morf.export.compiled_tail`) is the finest pull level
of :func:`morf.avatar.renderer.push_pull_fill` on the texture's colour channels: a pyramid of 2x2
means and bilinear pulls over three colour planes and the coverage. In onnxruntime-web it is
about 80 small nodes, the full-resolution ones reading the raster's 16 bytes a pixel (a quarter of
the graph's kernel time on the demo avatar at 640 x 640); the same arithmetic is one short loop
in JavaScript over bytes the page has read back already (``resources/web/fill.js``).

So the web export drops FILL from the graph and writes its level count beside the tail's spec
(``fill_levels``); the page computes it. The count is not taken from the training config: the
graph's own FILL is compared with :func:`fill_pyramid` on a test raster for each count, and only
a count that matches is used (otherwise the graph keeps its fill). Every halving of the pyramid
is exact (even sides) where the page's windows are multiples of ``2**levels``: the rewrite
applies only when the avatar's size multiple is.
"""

from __future__ import annotations

import numpy as np

from morf.export.compiled_tail import up_bilinear_2x

COVERAGE_FLOOR = 1e-4  # push_pull_fill's floor on a level's coverage before dividing by it
PROBE_SHAPE = (256, 384)  # the test raster: both sides divisible by 2**7
MAX_LEVELS = 7
MATCH_ATOL = 1e-4


def _halve(p: np.ndarray) -> np.ndarray:
    """(C, H, W) with even sides -> (C, H/2, W/2): the 2x2 mean."""
    return 0.25 * (p[:, 0::2, 0::2] + p[:, 1::2, 0::2] + p[:, 0::2, 1::2] + p[:, 1::2, 1::2])


def fill_pyramid(raster: np.ndarray, colour_scale, zero_point: int, coverage_channel: int, levels: int) -> np.ndarray:
    """The graph's FILL from an (H, W, 16) uint8 raster: (4, H/2, W/2) float32, colour x weight
    and the weight of the finest pull level. ``H`` and ``W`` must be divisible by ``2**levels``."""
    h, w = raster.shape[:2]
    if levels < 1 or h % 2 ** levels or w % 2 ** levels:
        raise ValueError(f"a {h} x {w} raster does not halve exactly {levels} times")
    rgb = (raster[..., :3].astype(np.float32) - zero_point) * np.asarray(colour_scale, np.float32)
    covered = (raster[..., coverage_channel] != zero_point).astype(np.float32)
    cols, covs = [_halve(rgb.transpose(2, 0, 1))], [_halve(covered[None])]
    for _ in range(levels - 1):
        cols.append(_halve(cols[-1]))
        covs.append(_halve(covs[-1]))
    acc = np.concatenate([cols[-1], covs[-1]])
    for col, cov in zip(reversed(cols[:-1]), reversed(covs[:-1])):
        a = np.minimum(cov * 4, 1.0)
        own = np.concatenate([col / np.maximum(cov, COVERAGE_FLOOR), np.ones_like(cov)])
        acc = a * own + (1 - a) * up_bilinear_2x(acc)
    return acc.astype(np.float32)


def probe_raster(zero_point: int, coverage_channel: int = 0, seed: int = 0) -> np.ndarray:
    """A test raster: a few covered rectangles of random bytes (the coverage channel never at the
    zero point there) on the zero point, with wide empty stretches between them, so that fills of
    different reach differ."""
    rng = np.random.default_rng(seed)
    h, w = PROBE_SHAPE
    raster = np.full((h, w, 16), zero_point, np.uint8)
    for y0, x0, y1, x1 in ((20, 30, 90, 70), (150, 200, 230, 240), (40, 300, 60, 370)):
        block = rng.integers(0, 256, (y1 - y0, x1 - x0, 16), dtype=np.uint8)
        mark = block[..., coverage_channel]
        mark[mark == zero_point] = zero_point + 1
        raster[y0:y1, x0:x1] = block
    return raster


def fill_levels_of(graph: bytes, spec) -> int | None:
    """The level count whose :func:`fill_pyramid` gives the cut graph's FILL output (``spec``: the
    tail's :class:`morf.export.compiled_tail.TailSpec`) on :func:`probe_raster`, or None when none
    up to :data:`MAX_LEVELS` does."""
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.log_severity_level = 3
    session = ort.InferenceSession(graph, options, providers=["CPUExecutionProvider"])
    raster = probe_raster(spec.zero_point, spec.coverage_channel)
    (got,) = session.run([spec.fill], {session.get_inputs()[0].name: raster[None]})
    got = np.asarray(got, np.float32)[0]
    for levels in range(1, MAX_LEVELS + 1):
        want = fill_pyramid(raster, spec.colour_scale, spec.zero_point, spec.coverage_channel, levels)
        if want.shape == got.shape and float(np.abs(want - got).max()) <= MATCH_ATOL:
            return levels
    return None


def without_fill(graph: bytes, spec, size_multiple: int) -> tuple[bytes, int | None]:
    """The cut graph without its FILL output (and the nodes only it needed) and the level count the
    page computes it with; the graph unchanged and None when its fill does not match
    :func:`fill_pyramid` or the avatar's windows would not halve exactly."""
    import onnx

    from morf.web.graph_rewrite import _prune

    levels = fill_levels_of(graph, spec)
    if levels is None or size_multiple % 2 ** levels:
        return graph, None
    model = onnx.load_from_string(graph)
    keep = [o for o in model.graph.output if o.name != spec.fill]
    del model.graph.output[:]
    model.graph.output.extend(keep)
    _prune(model.graph)
    return model.SerializeToString(), levels
