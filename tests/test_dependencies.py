"""The distributions pyproject.toml declares are exactly the ones morf/ and studio/ import.

Every import statement of every source file is read with ``ast`` (also those inside functions,
and ``importlib.import_module("name")`` with a literal name), each third-party module is mapped to
the distribution that installs it (``importlib.metadata.packages_distributions``), and the set is
compared with the declared dependencies (core and extras; the ``test`` extra is the tests'). The
few exceptions are listed below, each with its reason. The tests' own third-party imports must come
from a declared distribution or one that a declared distribution requires.
"""

from __future__ import annotations

import ast
import importlib.metadata as md
import re
import sys
from pathlib import Path

import pytest

from tests.conftest import strict_install

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    tomllib = pytest.importorskip("tomli")

REPO = Path(__file__).resolve().parents[1]
SOURCES = ("morf", "studio")

# Imported, not declared: optional at run time, the import guarded where it is made.
OPTIONAL_IMPORTS = {
    "mediapipe": "MediaPipe 0.10.14 declares jax and the non-headless OpenCV (which must not sit beside the "
                 "headless one); scripts/install.sh installs it with --no-deps, morf/capture/detect_mediapipe.py "
                 "says in one line how to install it, and morf synth / morf demo go on without it",
}
# Declared, not imported: what MediaPipe needs at run time (mediapipe itself comes without its
# dependency list, see above).
NOT_IMPORTED = {
    "absl-py": "MediaPipe's",
    "attrs": "MediaPipe's",
    "flatbuffers": "MediaPipe's",
    "protobuf": "MediaPipe's (and onnx's)",
}
# MediaPipe 0.10.14's requirements that are deliberately not installed: its pose solution needs
# none of them, and opencv-contrib-python would replace the headless cv2.
MEDIAPIPE_LEFT_OUT = {"jax", "jaxlib", "opencv-contrib-python", "sounddevice"}


def canonical(name: str) -> str:
    """A distribution name as PEP 503 compares them: ``Pillow`` -> ``pillow``, ``absl_py`` -> ``absl-py``."""
    return re.sub(r"[-_.]+", "-", name).lower()


def requirement_name(requirement: str) -> str:
    return canonical(re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)", requirement).group(1))


def declared(extras: bool = True, test: bool = False) -> set[str]:
    """Distributions pyproject.toml declares: core, and the extras other than ``test`` (and it too)."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    reqs = list(project["dependencies"])
    for extra, more in project.get("optional-dependencies", {}).items():
        if extras and (extra != "test" or test):
            reqs += more
    return {requirement_name(r) for r in reqs}


def imported_modules(roots: list[Path], calls: bool = True) -> dict[str, set[str]]:
    """Top-level module -> files importing it, for every absolute import under ``roots`` (with
    ``calls``, also ``import_module("name")``: the tests import missing names on purpose)."""
    found: dict[str, set[str]] = {}
    for root in roots:
        for path in sorted(root.rglob("*.py")):
            tree = ast.parse(path.read_text(), str(path))
            for node in ast.walk(tree):
                names = []
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                elif (calls and isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "import_module"
                      and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
                    names = [node.args[0].value]
                for name in names:
                    found.setdefault(name.split(".")[0], set()).add(str(path.relative_to(REPO)))
    return found


def third_party(modules: dict[str, set[str]], local: set[str]) -> dict[str, set[str]]:
    return {m: f for m, f in modules.items() if m not in sys.stdlib_module_names and m not in local}


def distributions_of(modules: dict[str, set[str]]) -> tuple[dict[str, set[str]], list[str]]:
    """(distribution -> modules, modules no installed distribution provides)."""
    table = md.packages_distributions()
    out: dict[str, set[str]] = {}
    missing = []
    for m in modules:
        dists = table.get(m)
        if not dists:
            missing.append(m)
            continue
        for d in dists:
            out.setdefault(canonical(d), set()).add(m)
    return out, sorted(missing)


def test_declared_dependencies_are_the_imported_ones():
    modules = third_party(imported_modules([REPO / s for s in SOURCES]), set(SOURCES))
    optional = {m: modules.pop(m) for m in list(modules) if m in OPTIONAL_IMPORTS}
    assert set(optional) == set(OPTIONAL_IMPORTS), "an optional import listed here is no longer made"
    dists, missing = distributions_of(modules)
    if missing:  # an extra not installed here, or an import nobody declared: CI installs every extra
        why = ("imported but installed by no distribution (declare it in pyproject.toml and install): "
               + ", ".join(f"{m} ({sorted(modules[m])[0]})" for m in missing))
        if not strict_install():
            pytest.skip(why)
        pytest.fail(why, pytrace=False)
    want = declared() - set(NOT_IMPORTED)
    undeclared = {d: sorted(dists[d]) for d in set(dists) - want}
    unused = sorted(want - set(dists))
    assert not undeclared, f"imported but not declared in pyproject.toml: {undeclared}"
    assert not unused, f"declared in pyproject.toml but imported nowhere in morf/ or studio/: {unused}"


def test_the_exceptions_hold():
    """Every name in the lists above is what it says: optional imports are not declared, and what is
    declared for MediaPipe is declared and really on MediaPipe's own list."""
    assert not set(OPTIONAL_IMPORTS) & declared(test=True)
    assert set(NOT_IMPORTED) <= declared(extras=False)
    try:
        requires = md.requires("mediapipe") or []
    except md.PackageNotFoundError:
        if strict_install():
            pytest.fail("mediapipe is not installed although scripts/install.sh installs it", pytrace=False)
        pytest.skip("mediapipe is not installed")
    theirs = {requirement_name(r) for r in requires if "extra ==" not in r}
    assert set(NOT_IMPORTED) <= theirs
    assert theirs - declared(extras=False) == MEDIAPIPE_LEFT_OUT, "MediaPipe's requirements changed: review the lists"


def test_mediapipe_is_installed_without_its_dependency_list():
    """scripts/install.sh pins the MediaPipe it installs and installs it with --no-deps."""
    script = (REPO / "scripts" / "install.sh").read_text()
    assert re.search(r"pip install [^\n]*--no-deps [^\n]*\"mediapipe==0\.10\.14\"", script)


def _requirements_closure(names: set[str]) -> set[str]:
    """``names`` and every distribution they require, installed ones only."""
    seen, todo = set(), list(names)
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        try:
            reqs = md.requires(name) or []
        except md.PackageNotFoundError:
            continue
        todo += [requirement_name(r) for r in reqs if "extra ==" not in r]
    return seen


def test_tests_import_only_what_is_installed_with_the_project():
    tests = REPO / "tests"
    local = {p.stem for p in tests.rglob("*.py")} | {p.name for p in tests.rglob("*") if p.is_dir()}
    local |= {"tests", *SOURCES}
    modules = third_party(imported_modules([tests], calls=False), local)
    modules = {m: f for m, f in modules.items() if m not in OPTIONAL_IMPORTS}
    dists, missing = distributions_of(modules)
    if missing:
        why = f"the tests import modules no installed distribution provides: {missing}"
        if not strict_install():
            pytest.skip(why + " (install the test extras)")
        pytest.fail(why, pytrace=False)
    allowed = _requirements_closure(declared(test=True))
    stray = {d: sorted(dists[d]) for d in set(dists) - allowed}
    assert not stray, f"the tests import distributions pyproject.toml brings neither directly nor through another: {stray}"
