"""Where the page's own files lie: ``resources/web/`` through morf's one loader of shipped files."""

from __future__ import annotations

from pathlib import Path


def page_files() -> list[Path]:
    """The page's static files (index.html, the player's scripts, its style sheet), sorted."""
    from morf.resources import resource

    root = resource("web")
    return sorted(p for p in root.iterdir() if p.is_file() and p.suffix in (".html", ".js", ".mjs", ".css"))
