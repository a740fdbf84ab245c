"""The layer contract of ``morf/``: a module imports only from its own layer or the layers below it,
and never from the desktop app (``studio/``); and no two files import each other, directly or
round a circle. docs/architecture.md draws the same order.

Every import counts: at the top of a module, inside a function, under ``TYPE_CHECKING``, through
``importlib.import_module`` (a constant name or an f-string's constant prefix), in code handed
to a child interpreter as a string (``python -c "from morf... import ..."``), and a string that
names a module of the project (``"morf.fitting.fit"`` in a table of lazy attributes,
``"studio.bench"`` run as ``python -m studio.bench``): whatever loads a module, in this process
or a child, depends on it. The one crossing into the app is a process boundary listed in
:data:`APP_PROCESSES`.
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

import pytest

MORF = Path(__file__).resolve().parents[1] / "morf"
STUDIO = MORF.parent / "studio"

# Lowest first. A layer may import itself and any layer before it. Within "foundation" the small
# shared modules may import each other.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("foundation", ("morf", "morf.errors", "morf.config_checks", "morf.io", "morf.camera", "morf.progress",
                    "morf.pipeline", "morf.resources", "morf.lazy")),  # resources: the loader of the shipped files; lazy: package attributes on first use
    ("machine", ("morf.machine",)),  # CPU capability probes, CPUID mask, AMX permission, numba probe
    ("scale", ("morf.scale",)),  # Ray: where tasks run, what they hold, a list of calls run as tasks
    ("capture", ("morf.capture",)),  # the project folder, video, keypoints, masks
    ("datasets", ("morf.datasets",)),  # standard datasets imported as capture projects
    ("body", ("morf.body",)),  # body model, render mesh, skinning
    ("raster", ("morf.raster",)),  # rasterization: UV maps, soft silhouette, the GL neural rasterizer
    ("synth", ("morf.synth",)),  # synthetic capture projects, rendered with body + raster
    ("fitting", ("morf.fitting",)),  # body fits (fits/fits.npz)
    ("avatar", ("morf.avatar",)),  # neural texture, warp field, renderer, losses
    ("train", ("morf.train",)),  # training runs (runs/<name>/), the trained avatar file
    ("presets", ("morf.presets",)),  # the registry of every stage's named presets (synth, fit, train)
    ("sizing", ("morf.sizing",)),  # --preset auto: the automatic size choice
    ("motion", ("morf.motion",)),  # motion files (a capture's fits among them), retargeting
    ("export", ("morf.export",)),  # the avatar folder, int8 ONNX, glTF (animations from motion)
    ("playback", ("morf.playback",)),  # torch-free player of an avatar folder
    ("web", ("morf.web",)),  # the browser player's build: an avatar folder and motions for resources/web
    ("evaluate", ("morf.evaluate",)),  # morf eval
    ("bench", ("morf.bench",)),  # morf bench
    ("cli", ("morf.cli",)),  # morf ...
)
RANK = {prefix: i for i, (_, prefixes) in enumerate(LAYERS) for prefix in prefixes}
NAME = [name for name, _ in LAYERS]
FORBIDDEN = ("studio",)  # the app is built on morf, never the other way round
# (morf module, app module) pairs where morf starts the app's module as a program of its own
# (``python -m``): it never runs in morf's process, and the app gets a fresh GLFW and GL state.
APP_PROCESSES = {
    ("morf.cli.bench", "studio.bench"): "morf bench studio: the studio window measured in its own process",
}
# File circles not yet broken, each with why it is still there; the test fails on any other
# circle, and on one of these once it is gone (so the list only shrinks).
KNOWN_CIRCLES: dict[frozenset, str] = {}  # none left; a new circle fails the test
MODULE_NAME = re.compile(r"(morf|studio)(\.[A-Za-z_]\w*)+")


def layer_of(module: str) -> int | None:
    """Rank of the layer a dotted module name belongs to (its longest listed prefix), or None."""
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        rank = RANK.get(".".join(parts[:n]))
        if rank is not None:
            return rank
    return None


def module_name(path: Path) -> str:
    rel = path.relative_to(MORF.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _docstrings(tree: ast.AST) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def _import_module_target(call: ast.Call) -> str | None:
    f = call.func
    name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None
    if name not in ("import_module", "__import__") or not call.args:
        return None
    arg = call.args[0]
    if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
        return arg.value
    if isinstance(arg, ast.JoinedStr) and arg.values and isinstance(arg.values[0], ast.Constant):
        return str(arg.values[0].value).rstrip(".")  # f"morf.raster.{name}" -> morf.raster
    return None


def imports_of(source: str, module: str = "", filename: str = "<string>") -> list[tuple[int, str]]:
    """(line, imported dotted name) of every import in ``source``; ``module``: its dotted name
    (resolves relative imports). For ``from a.b import c`` both ``a.b`` and ``a.b.c`` are listed,
    since ``c`` may be a module."""
    tree = ast.parse(source, filename)
    docs = _docstrings(tree)
    package = module if filename.endswith("__init__.py") else module.rpartition(".")[0]
    out: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # from . import x, from ..train import data
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            out.append((node.lineno, base))
            out += [(node.lineno, f"{base}.{a.name}") for a in node.names if a.name != "*"]
        elif isinstance(node, ast.Call):
            target = _import_module_target(node)
            if target:
                out.append((node.lineno, target))
        elif (isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs
              and MODULE_NAME.fullmatch(node.value) and node.value in project_modules()):
            out.append((node.lineno, node.value))  # a module named to be loaded: lazily, or by a child (-m)
        elif (isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs
              and "import" in node.value and ("morf" in node.value or "studio" in node.value)):
            try:  # code run by a child interpreter
                inner = imports_of(node.value, module)
            except SyntaxError:
                continue
            out += [(node.lineno, name) for _, name in inner]
    return out


def _dotted(path: Path) -> str:
    parts = list(path.relative_to(MORF.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@functools.cache
def project_modules() -> frozenset[str]:
    """Dotted names of every module and package of morf/ and studio/."""
    return frozenset(_dotted(p) for root in (MORF, STUDIO) for p in root.rglob("*.py"))


def upward_imports(source: str, module: str, filename: str = "<string>") -> list[tuple[int, str, str]]:
    """(line, imported name, why) of each import in ``source`` (the text of ``module``) that
    breaks the layer contract; one per line and imported layer."""
    own = layer_of(module)
    out, seen = [], set()
    for line, name in imports_of(source, module, filename):
        top = name.split(".")[0]
        rank = layer_of(name) if top == "morf" else None
        if top in FORBIDDEN and (module, name) in APP_PROCESSES:
            continue
        if top in FORBIDDEN:
            key, why = (line, top), "morf never imports the app"
        elif own is not None and rank is not None and rank > own:
            key, why = (line, rank), f"{NAME[own]} imports {NAME[rank]}, a higher layer"
        else:
            continue
        if key not in seen:  # ``from a.b import c``: a.b and a.b.c are one import
            seen.add(key)
            out.append((line, name, why))
    return out


def violations(source: str, module: str, filename: str = "<string>") -> list[str]:
    """The upward imports of ``source`` as readable lines."""
    return [f"{filename}:{line}: {module} imports {name} ({why})"
            for line, name, why in upward_imports(source, module, filename)]


def morf_modules() -> list[Path]:
    return sorted(MORF.rglob("*.py"))


def test_every_module_has_a_layer():
    unplaced = sorted({module_name(p) for p in morf_modules() if layer_of(module_name(p)) is None})
    assert not unplaced, f"modules in no layer (add their package to LAYERS in tests/test_layers.py): {unplaced}"


def test_imports_only_go_down():
    files = morf_modules()
    assert len(files) > 100  # the walk found the library
    bad = []
    for path in files:
        bad += violations(path.read_text(encoding="utf-8"), module_name(path), str(path.relative_to(MORF.parent)))
    assert not bad, "imports from a higher layer:\n" + "\n".join(bad)


@pytest.mark.parametrize("source, reported", [
    ("from morf.train.data import load_body_fits\n", True),  # top of the module
    ("def f():\n    from morf.playback.player import Player\n", True),  # inside a function
    ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import morf.bench.render\n", True),
    ("import importlib\nm = importlib.import_module('morf.export.avatar_folder')\n", True),
    ("import importlib\ndef g(n):\n    return importlib.import_module(f'morf.cli.{n}')\n", True),
    ("CODE = \"import sys\\nfrom morf.evaluate.runs import RunDir; RunDir\"\n", True),  # a child's code
    ("from morf import cli\n", True),  # a package imported by its name
    ("import studio.app\n", True),
    ("def f():\n    from studio.panels import help\n", True),
    ("from morf.body import load_body_model\nfrom morf.raster import rasterize_uv\n", False),  # down, own layer
    ("from morf.errors import InputError\nimport numpy\n", False),
    ('"""from morf.cli.main import main"""\n', False),  # a docstring is never run
])
def test_a_synthetic_upward_import_is_reported(source, reported):
    found = violations(source, "morf.raster.example")
    assert bool(found) == reported, found


def test_relative_imports_are_resolved():
    assert violations("from ..train import data\n", "morf.raster.example") != []
    assert violations("from . import gl_mesh\n", "morf.raster.example") == []
    assert violations("from .gl_mesh import rasterize_uv\n", "morf.raster", "morf/raster/__init__.py") == []


def file_graph() -> dict[str, set[str]]:
    """Each morf module -> the morf modules (files) it imports, every kind of import counted."""
    mods = {module_name(p): p for p in morf_modules()}

    def resolve(name: str) -> str | None:  # ``from a.b import c``: a.b.c when it is a module, else a.b
        parts = name.split(".")
        return next((".".join(parts[:n]) for n in range(len(parts), 0, -1) if ".".join(parts[:n]) in mods), None)

    graph = {}
    for m, path in mods.items():
        found = [(line, name) for line, name in imports_of(path.read_text(encoding="utf-8"), m, str(path))
                 if name.split(".")[0] == "morf"]
        # ``from morf.fitting import frame_spacing`` depends on the submodule, not on the package's
        # other names (its __init__ runs first, as every parent package's does; that is no edge)
        beside = {(line, name.rpartition(".")[0]) for line, name in found if name in mods}
        targets = {resolve(name) for line, name in found if (line, name) not in beside}
        graph[m] = {t for t in targets if t is not None and t != m}
    return graph


def circles(graph: dict[str, set[str]]) -> list[frozenset[str]]:
    """The strongly connected groups of more than one file (Tarjan, iterative)."""
    index, low, on, stack, found, counter = {}, {}, set(), [], [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                group = set()
                while True:
                    w = stack.pop()
                    on.discard(w)
                    group.add(w)
                    if w == v:
                        break
                if len(group) > 1:
                    found.append(frozenset(group))
    return found


def test_no_import_circles_between_files():
    found = set(circles(file_graph()))
    new = [sorted(c) for c in found - set(KNOWN_CIRCLES)]
    gone = [sorted(c) for c in set(KNOWN_CIRCLES) - found]
    assert not new, f"files that import each other (round a circle): {new}"
    assert not gone, f"circles broken: remove them from KNOWN_CIRCLES in tests/test_layers.py: {gone}"


def test_a_circle_is_found_round_three_files():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"e"}}
    assert circles(graph) == [frozenset("abc")]


def test_a_module_started_as_a_child_program_is_an_import():
    src = "import subprocess, sys\nsubprocess.run([sys.executable, '-m', 'morf.cli.main', 'play'])\n"
    assert violations(src, "morf.raster.example") != []
    apps = "APPS = {'studio': 'studio.bench'}\ndef f(a):\n    return [sys.executable, '-m', APPS[a]]\n"
    assert any("never imports the app" in v for v in violations(apps, "morf.raster.example"))
    assert violations(apps, "morf.cli.bench") == []  # the one listed process boundary
    assert violations("NAME = 'morf.no_such_module'\nWORD = 'studio.json'\n", "morf.raster.example") == []


def test_the_app_processes_listed_are_started_where_listed():
    for (module, app), why in APP_PROCESSES.items():
        path = MORF.parent / module.replace(".", "/")
        path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
        assert app in {name for _, name in imports_of(path.read_text(encoding="utf-8"), module)}, why
        assert app in project_modules()


def test_the_cli_names_the_cpu_classes_of_the_mask():
    from morf.cli.bench import CPU_CLASSES
    from morf.machine.cpuid_mask import CLASSES

    assert sorted(CPU_CLASSES) == sorted(CLASSES)


def test_the_player_and_the_cli_start_without_the_machine_probes():
    """The CPU probes and benchmark tricks (morf.machine) load only where asked, never when the
    command line or the player is imported."""
    import subprocess
    import sys

    code = ("import sys, morf.cli.main, morf.playback.player, morf.playback.native_tail; "
            "morf.cli.main.build_parser(); "  # every command builds the whole parser, morf bench's included
            "print(sorted(m for m in sys.modules if m.startswith('morf.machine')))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=MORF.parent)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"
