"""The shipped files live in the top-level ``resources/`` folder, every user reaches them through
:mod:`morf.resources`, and a wheel built from the tree carries every one of them where the loader
finds them once installed."""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from morf.errors import MorfError
from morf.resources import FONT, MOTIONS, ROOT, SHADERS, WEB, resource, shader_source

REPO = Path(__file__).resolve().parents[1]
WHEEL_SOURCES = ("pyproject.toml", "setup.py", "README.md", "morf", "studio", "resources")


def shipped_files() -> list[str]:
    return sorted(p.relative_to(ROOT).as_posix() for p in ROOT.rglob("*")
                  if p.is_file() and "__pycache__" not in p.parts)


def test_the_checkout_reads_the_top_level_folder():
    assert ROOT == REPO / "resources"
    assert FONT.is_file() and SHADERS.is_dir() and sorted(MOTIONS.glob("*.npz"))
    assert WEB.parent == ROOT  # the browser player's folder is served by the same loader
    assert "#version" in shader_source("neural_raster_vs.glsl")


def test_a_missing_shipped_file_is_one_line_naming_it():
    with pytest.raises(MorfError, match=r"shipped file shaders/nope\.glsl is missing.*reinstall"):
        resource("shaders", "nope.glsl")


def test_a_stage_gets_its_includes_and_defines():
    """The UV rasterizer's and the textured renderer's vertex stages share one included body;
    each gets only its own outputs, and defines land right after the #version line."""
    mesh, textured = shader_source("gl_mesh_vs.glsl"), shader_source("gl_textured_vs.glsl")
    for text in (mesh, textured):
        assert not re.search(r"^\s*#include", text, re.MULTILINE)
        assert text.startswith("#version 330\n") and "gl_Position = proj * pc;" in text
    assert "#define POSED_DEPTH" in mesh and "#define POSED_NORMAL" not in mesh
    assert "#define POSED_NORMAL" in textured and "#define POSED_DEPTH" not in textured
    bones = shader_source("neural_raster_vs.glsl", {"NUM_BONES": 7})
    assert bones.splitlines()[:2] == ["#version 330 core", "#define NUM_BONES 7"]
    assert bones.replace("#define NUM_BONES 7\n", "", 1) == shader_source("neural_raster_vs.glsl")


def test_an_include_circle_is_one_line(tmp_path, monkeypatch):
    import morf.resources as r

    (tmp_path / "shaders").mkdir()
    (tmp_path / "shaders" / "a.glsl").write_text('#version 330\n#include "b.glsl"\n')
    (tmp_path / "shaders" / "b.glsl").write_text('#include "a.glsl"\n')
    monkeypatch.setattr(r, "ROOT", tmp_path)
    with pytest.raises(MorfError, match="nests deeper"):
        r.shader_source("a.glsl")
    with pytest.raises(MorfError, match="shipped file shaders/c.glsl is missing"):
        (tmp_path / "shaders" / "a.glsl").write_text('#version 330\n#include "c.glsl"\n')
        r.shader_source("a.glsl")


def _code_strings(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docs = {id(n.body[0].value) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and n.body
            and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
    return [(n.lineno, n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs]


def test_no_module_finds_a_shipped_file_around_the_loader():
    """Shipped files are found through morf.resources alone: no other module spells their folder."""
    offenders = [f"{path.relative_to(REPO)}:{line}: {text!r}"
                 for path in [*(REPO / "morf").rglob("*.py"), *(REPO / "studio").rglob("*.py")]
                 if path != REPO / "morf" / "resources.py"
                 for line, text in _code_strings(path)
                 if text in ("resources", "_resources") or text.startswith(("resources/", "morf/resources"))]
    assert not offenders, "\n".join(offenders)


# Modules that still reach from their own file into the checkout, which an installed wheel does not
# have (each to be moved behind morf.resources or a user cache, then taken off this list).
CHECKOUT_READERS: dict[str, str] = {}


def _levels_up_from_the_file(node: ast.AST) -> int | None:
    """How many folders ``node`` climbs from ``Path(__file__)`` (``.parent`` one, ``.parents[k]``
    k + 1, through ``.resolve()``), or None when it does not start at ``__file__``."""
    levels = 0
    while True:
        if isinstance(node, ast.Attribute) and node.attr == "parent":
            levels, node = levels + 1, node.value
        elif (isinstance(node, ast.Subscript) and isinstance(node.value, ast.Attribute) and node.value.attr == "parents"
              and isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, int)):
            levels, node = levels + node.slice.value + 1, node.value.value
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in ("resolve", "absolute"):
            node = node.func.value
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Name) and node.args[0].id == "__file__":
            return levels
        else:
            return None


def test_no_module_reads_from_the_checkout():
    """Beside the one loader (which tells an installed package from a checkout), no module climbs
    from its own file out of the package: an installed wheel has nothing there."""
    found = set()
    for path in [*(REPO / "morf").rglob("*.py"), *(REPO / "studio").rglob("*.py")]:
        name = path.relative_to(REPO).as_posix()
        if name == "morf/resources.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            up = _levels_up_from_the_file(node)
            if up is not None and up >= len(path.relative_to(REPO).parts):  # above morf/ or studio/
                found.add(name)
    assert found == set(CHECKOUT_READERS), (f"modules reading from the checkout: {sorted(found - set(CHECKOUT_READERS))}; "
                                            f"no longer (take them off CHECKOUT_READERS): {sorted(set(CHECKOUT_READERS) - found)}")


@pytest.fixture(scope="module")
def built_wheel(tmp_path_factory) -> Path:
    """The wheel of a copy of the tree (so the build leaves nothing in the working tree), built
    offline by the setuptools of this environment."""
    src = tmp_path_factory.mktemp("src")
    for name in WHEEL_SOURCES:
        if (REPO / name).is_dir():
            shutil.copytree(REPO / name, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(REPO / name, src / name)
    out = tmp_path_factory.mktemp("wheel")
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", str(src), "--no-deps", "--no-build-isolation", "--no-index",
                        "-q", "-w", str(out)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    (wheel,) = out.glob("morf_studio-*.whl")
    return wheel


def test_the_wheel_carries_every_shipped_file(built_wheel):
    names = set(zipfile.ZipFile(built_wheel).namelist())
    files = shipped_files()
    assert len(files) >= 7  # font + licence, three motions, the shaders
    missing = [f for f in files if f"morf/_resources/{f}" not in names]
    assert not missing, f"shipped files left out of the wheel: {missing}"
    assert "morf/machine/cpuid_mask.c" in names and "morf/train/trainer.py" in names  # data and namespace packages


def _asked_for_by_the_code() -> set[str]:
    """Shipped files the code names: the GLSL of every ``shader_stages("x")`` / ``shader_source("y")``
    call with a literal name, the font, the demo's motion."""
    wanted = {"fonts/DejaVuSans.ttf", "fonts/DejaVuSans-LICENSE.txt", "motions/walk_forward.npz"}
    for path in [*(REPO / "morf").rglob("*.py"), *(REPO / "studio").rglob("*.py")]:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)):
                continue
            name = getattr(node.func, "id", getattr(node.func, "attr", None))
            if name == "shader_stages":
                wanted |= {f"shaders/{node.args[0].value}_vs.glsl", f"shaders/{node.args[0].value}_fs.glsl"}
            elif name == "shader_source":
                wanted.add(f"shaders/{node.args[0].value}")
    todo = [w for w in wanted if w.startswith("shaders/")]
    while todo:  # and the parts they include
        shader = todo.pop()
        text = (ROOT / shader).read_text(encoding="utf-8") if (ROOT / shader).is_file() else ""
        parts = {f"shaders/{m}" for m in re.findall(r'^\s*#include\s+"([^"]+)"', text, re.MULTILINE)}
        todo += sorted(parts - wanted)
        wanted |= parts
    return wanted


def _asked_for_by_the_page() -> set[str]:
    """The browser player's own files its page loads: index.html's ``src``/``href`` and the scripts'
    relative ``import ... from './x.js'`` (``lib/`` holds onnxruntime-web, copied in at export)."""
    web = ROOT / "web"
    wanted = {"web/index.html"}
    wanted |= {f"web/{m}" for m in re.findall(r'(?:src|href)="([^":/]+)"', (web / "index.html").read_text())}
    for script in web.glob("*.js"):
        wanted |= {f"web/{m}" for m in re.findall(r"from\s+'\./([^']+)'", script.read_text())}
    return wanted


def test_the_wheel_carries_what_the_code_and_the_page_ask_for(built_wheel):
    """By kind: every shader a module compiles, the font and its licence, the sample motions, and
    the web player's page with every script and style sheet it loads."""
    names = {n.removeprefix("morf/_resources/") for n in zipfile.ZipFile(built_wheel).namelist()}
    code, page = _asked_for_by_the_code(), _asked_for_by_the_page()
    assert sum(f.startswith("shaders/") for f in code) >= 10 and len(page) >= 10  # the scan found the callers
    assert not code - names, f"the code asks for shipped files the wheel lacks: {sorted(code - names)}"
    assert not page - names, f"the web page loads files the wheel lacks: {sorted(page - names)}"
    assert {f"motions/{n}.npz" for n in ("idle_sway", "walk_in_place", "walk_forward")} <= names


def test_the_installed_wheel_finds_its_files_through_the_loader(built_wheel, tmp_path):
    """Installed into a bare folder and imported without the checkout on the path (``-S``: no
    site-packages, so the editable install of this checkout cannot answer instead)."""
    target = tmp_path / "site"
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "-q", "--target", str(target),
                        str(built_wheel)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    code = ("import sys; sys.path.insert(0, sys.argv[1]); import morf.resources as r; "
            "print(r.ROOT); print(r.FONT.is_file(), len(list(r.MOTIONS.glob('*.npz'))), "
            "'#version' in r.shader_source('neural_raster_fs.glsl'))")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    r = subprocess.run([sys.executable, "-S", "-c", code, str(target)], capture_output=True, text=True, cwd=tmp_path,
                       env=env, timeout=60)
    assert r.returncode == 0, r.stderr
    root, checks = r.stdout.splitlines()
    assert Path(root) == target / "morf" / "_resources"
    assert checks == f"True {len(list(MOTIONS.glob('*.npz')))} True"
    installed = sorted(p.relative_to(root).as_posix() for p in Path(root).rglob("*") if p.is_file())
    assert installed == shipped_files()
