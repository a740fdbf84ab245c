"""Window sizes as the command lines take them (``--size 1280x800``), shared by ``morf-studio`` and
the studio benchmark."""

from __future__ import annotations

from morf.errors import MorfError

MIN_WINDOW = (320, 240)  # the smallest window the panels still fit in


def parse_window_size(text: str) -> tuple[int, int]:
    """``"WxH"`` -> (W, H); a :class:`MorfError` for anything else or a window under :data:`MIN_WINDOW`."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
        if w < MIN_WINDOW[0] or h < MIN_WINDOW[1]:
            raise ValueError
        return w, h
    except ValueError:
        raise MorfError(f"--size wants WxH of at least {MIN_WINDOW[0]}x{MIN_WINDOW[1]}, got {text!r}") from None
