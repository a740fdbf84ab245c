"""The one way to the files the project ships in its top-level ``resources/`` folder: shaders,
the font of the comparison sheets and the studio, the sample motions (``python -m
morf.motion.procedural`` writes them) and the browser player (``resources/web/``).

In a source checkout (an editable install included) they are read where they lie; an installed
wheel carries the same tree as ``morf/_resources/`` (``setup.py`` maps the folder into the
package). Every user of a shipped file goes through this module, so both cases look the same.
"""

from __future__ import annotations

import re
from pathlib import Path

from morf.errors import MorfError

_HERE = Path(__file__).resolve().parent


def _root() -> Path:
    """The installed copy inside the package when there is one, else the checkout's folder beside
    the package (never a ``resources/`` folder that merely sits beside an installed package)."""
    installed = _HERE / "_resources"
    if installed.is_dir():
        return installed
    checkout = _HERE.parent
    if (checkout / "pyproject.toml").is_file() and (checkout / "resources").is_dir():
        return checkout / "resources"
    raise MorfError(f"the shipped files are missing: neither {installed} nor {checkout / 'resources'} exists; "
                    "reinstall morf-studio (pip install .)")


ROOT = _root()
SHADERS = ROOT / "shaders"  # GLSL of the GL rasterizers (name.vert / name.frag / *.glsl)
FONT = ROOT / "fonts" / "DejaVuSans.ttf"  # with its licence beside it
MOTIONS = ROOT / "motions"  # idle_sway, walk_in_place, walk_forward (.npz)
WEB = ROOT / "web"  # the browser player's page and scripts


def resource(*parts: str) -> Path:
    """The shipped file ``resources/<parts...>``; a one-line error when it is missing (a broken
    install), never a silent wrong path."""
    path = ROOT.joinpath(*parts)
    if not path.exists():
        raise MorfError(f"shipped file {'/'.join(parts)} is missing from {ROOT}; reinstall morf-studio (pip install .)")
    return path


# GLSL has no include of its own: a stage's ``#include "file.glsl"`` line is replaced by that file's
# text (a part shared by several stages, itself without a #version line).
_INCLUDE = re.compile(r'^[ \t]*#include[ \t]+"([\w.-]+)"[ \t]*$', re.MULTILINE)
_MAX_INCLUDE_DEPTH = 4


def shader_source(name: str, defines: dict[str, object] | None = None) -> str:
    """The text of ``resources/shaders/<name>`` (a GLSL stage), with its ``#include`` lines filled
    in and ``defines`` (name -> value) as ``#define`` lines right after its ``#version`` line, where
    GLSL wants them (a program compiled in several variants, e.g. its bone count)."""
    text = _with_includes(name, 0)
    if defines:
        version, newline, rest = text.partition("\n")
        if not version.startswith("#version"):
            raise MorfError(f"shader {name} must start with a #version line to take defines")
        text = version + newline + "".join(f"#define {k} {v}\n" for k, v in defines.items()) + rest
    return text


def _with_includes(name: str, depth: int) -> str:
    if depth > _MAX_INCLUDE_DEPTH:
        raise MorfError(f"shader include {name} nests deeper than {_MAX_INCLUDE_DEPTH} files (an include circle?)")
    text = resource("shaders", name).read_text(encoding="utf-8")
    return _INCLUDE.sub(lambda m: _with_includes(m.group(1), depth + 1).rstrip("\n"), text)


def shader_stages(stem: str) -> dict[str, str]:
    """``vertex_shader`` and ``fragment_shader`` of the program ``stem`` (``<stem>_vs.glsl``,
    ``<stem>_fs.glsl``), as moderngl's ``ctx.program(**shader_stages(stem))`` takes them."""
    return {"vertex_shader": shader_source(f"{stem}_vs.glsl"), "fragment_shader": shader_source(f"{stem}_fs.glsl")}
