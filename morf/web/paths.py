"""Where the page's own files lie: ``resources/web/`` through morf's one loader of shipped files,
and the shaders it shares with the Python player (``resources/shaders/``: one GLSL source for
both; the page turns its ``#version`` line into GLSL ES's)."""

from __future__ import annotations

from pathlib import Path


SHARED_SHADERS = ("neural_raster_fs.glsl",)  # the neural rasterization's fragment shader (raster.js)


def page_files() -> list[Path]:
    """The page's static files (index.html, the player's scripts, its style sheet, the shared
    shaders), sorted by name."""
    from morf.resources import resource

    root = resource("web")
    files = [p for p in root.iterdir() if p.is_file() and p.suffix in (".html", ".js", ".mjs", ".css")]
    files += [resource("shaders") / name for name in SHARED_SHADERS]
    return sorted(files, key=lambda p: p.name)
