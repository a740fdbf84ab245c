"""Golden screenshots: compare with a normalised RMSE, refresh with REGENERATE_GOLDEN=1.

On a mismatch the actual image, the golden one and a magnified difference are written to
tests/_failures/ (ignored by git).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from morf.io import read_image, write_image

TESTS = Path(__file__).resolve().parents[1]
GOLDEN = TESTS / "golden"
FAILURES = TESTS / "_failures"
WINDOW = (1280, 800)  # the studio's window size in every screenshot test (width, height)
UI_TOLERANCE = 0.006  # RMSE / 255; identical renders give 0, another Mesa build a little more
DIFF_GAIN = 8.0  # magnification of the difference image


def nrmse(a: np.ndarray, b: np.ndarray) -> float:
    d = a.astype(np.float64) - b.astype(np.float64)
    return float(np.sqrt(np.mean(d * d)) / 255.0)


def check_golden(name: str, image: np.ndarray, *, tolerance: float = UI_TOLERANCE,
                 ignore: tuple[tuple[int, int, int, int], ...] = ()) -> None:
    """Compare (H, W, 3) uint8 ``image`` with tests/golden/<name>.png.

    ``ignore``: (x0, y0, x1, y1) rectangles blanked in both images before comparing (timings).
    """
    path = GOLDEN / f"{name}.png"
    image = np.ascontiguousarray(image)
    if os.environ.get("REGENERATE_GOLDEN"):
        write_image(path, image)
        return
    assert path.is_file(), f"no golden image {path}; run the tests with REGENERATE_GOLDEN=1 to make it"
    golden = read_image(path)
    assert golden.shape == image.shape, f"{name}: size {image.shape} differs from golden {golden.shape}"
    a, b = image.copy(), golden.copy()
    for x0, y0, x1, y1 in ignore:
        a[y0:y1, x0:x1] = 0
        b[y0:y1, x0:x1] = 0
    err = nrmse(a, b)
    if err > tolerance:
        FAILURES.mkdir(exist_ok=True)
        diff = np.clip(np.abs(a.astype(np.int16) - b.astype(np.int16)).astype(np.float64) * DIFF_GAIN, 0, 255)
        write_image(FAILURES / f"{name}.actual.png", image)
        write_image(FAILURES / f"{name}.golden.png", golden)
        write_image(FAILURES / f"{name}.diff.png", diff.astype(np.uint8))
        raise AssertionError(f"{name}: screenshot differs from golden (NRMSE {err:.4f} > {tolerance}); "
                             f"see {FAILURES}/{name}.*.png")
