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
import functools
import importlib.metadata as md
import re
import sys
from pathlib import Path

import pytest
from packaging.requirements import Requirement

from tests.conftest import require, strict_install

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the test extra brings tomli there
    tomllib = require("tomli")

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
# In the test extra, not imported by the tests: a pytest plugin, loaded by its command-line flag.
TEST_PLUGINS = {"pytest-xdist": "scripts/test.sh runs the suite with -n"}
# Imports of these (the optional one and the extras) must sit inside functions, or in a try
# whose handler catches ImportError, so that the rest of morf imports without them.
GUARDED = (*OPTIONAL_IMPORTS, "av", "ray")
# MediaPipe 0.10.14's requirements that are deliberately not installed: its pose solution needs
# none of them, and opencv-contrib-python would replace the headless cv2.
MEDIAPIPE_LEFT_OUT = {"jax", "jaxlib", "opencv-contrib-python", "sounddevice"}


def canonical(name: str) -> str:
    """A distribution name as PEP 503 compares them: ``Pillow`` -> ``pillow``, ``absl_py`` -> ``absl-py``."""
    return re.sub(r"[-_.]+", "-", name).lower()


def requirement_name(requirement: str) -> str:
    return canonical(re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)", requirement).group(1))


def declared(extras: bool = True, test: bool = False, only: str | None = None) -> set[str]:
    """Distributions pyproject.toml declares for this Python: core, and the extras other than
    ``test`` (and it too); with ``only``, that extra alone."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    reqs = [] if only else list(project["dependencies"])
    for extra, more in project.get("optional-dependencies", {}).items():
        if extra == only or (only is None and extras and (extra != "test" or test)):
            reqs += more
    wanted = [Requirement(r) for r in reqs]
    return {canonical(r.name) for r in wanted if r.marker is None or r.marker.evaluate()}


def _called_with_a_name(node: ast.AST, functions: tuple[str, ...]) -> str | None:
    """``"name"`` of a call ``f("name")`` or ``x.f("name")`` with ``f`` in ``functions``."""
    if not (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)):
        return None
    f = node.func
    return node.args[0].value if getattr(f, "attr", getattr(f, "id", None)) in functions else None


@functools.cache
def parsed(path: Path) -> ast.Module:
    """A source file's syntax tree, read once per test run: the checks below read the same files."""
    return ast.parse(path.read_text(), str(path))


@functools.cache
def all_nodes(path: Path) -> tuple[ast.AST, ...]:
    """Every node of :func:`parsed` ``path`` (``ast.walk`` order), listed once per test run."""
    return tuple(ast.walk(parsed(path)))


@functools.cache
def module_distributions() -> dict[str, list[str]]:
    """``importlib.metadata.packages_distributions()``, once per test run: it reads every installed
    distribution's file list, which takes seconds."""
    return md.packages_distributions()


def imported_modules(roots: list[Path], calls: tuple[str, ...] = ("import_module",)) -> dict[str, set[str]]:
    """Top-level module -> files importing it, for every absolute import under ``roots``, and every
    call of one of ``calls`` with a literal module name (the tests import missing names on purpose
    with ``import_module``; they need a module through ``require``)."""
    found: dict[str, set[str]] = {}
    for root in roots:
        for path in sorted(root.rglob("*.py")):
            for node in all_nodes(path):
                names = []
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                elif (called := _called_with_a_name(node, calls)) is not None:
                    names = [called]
                for name in names:
                    found.setdefault(name.split(".")[0], set()).add(str(path.relative_to(REPO)))
    return found


def third_party(modules: dict[str, set[str]], local: set[str]) -> dict[str, set[str]]:
    return {m: f for m, f in modules.items() if m not in sys.stdlib_module_names and m not in local}


def distributions_of(modules: dict[str, set[str]]) -> tuple[dict[str, set[str]], list[str]]:
    """(distribution -> modules, modules no installed distribution provides)."""
    table = module_distributions()
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
    modules = third_party(imported_modules([tests], calls=()), local)
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


def test_every_test_extra_is_used_by_the_tests():
    """The other way round for the test extra: each of its distributions is imported (or needed
    through ``require``) by some test, or is a plugin with its reason above."""
    tests = REPO / "tests"
    modules = imported_modules([tests], calls=("import_module", "require", "importorskip"))
    wanted = declared(only="test") - set(TEST_PLUGINS)
    table = module_distributions()
    provided = {canonical(d) for m in modules for d in table.get(m, ())}
    absent = sorted(d for d in wanted if not _installed(d))
    if absent:
        why = f"the test extra is not installed: {absent} (pip install -e '.[test]')"
        if strict_install():
            pytest.fail(why, pytrace=False)
        pytest.skip(why)
    unused = sorted(wanted - provided)
    assert not unused, f"in pyproject.toml's test extra but needed by no test: {unused}"
    assert re.search(r"pytest [^\n]*-n ", (REPO / "scripts" / "test.sh").read_text()), TEST_PLUGINS["pytest-xdist"]


def _installed(distribution: str) -> bool:
    try:
        md.distribution(distribution)
    except md.PackageNotFoundError:
        return False
    return True


def _guarded_by_import_error(handlers: list[ast.ExceptHandler]) -> bool:
    names = {n.id for h in handlers for n in ast.walk(h.type) if isinstance(n, ast.Name)} if handlers else set()
    return bool(names & {"ImportError", "ModuleNotFoundError", "Exception"}) or any(h.type is None for h in handlers)


def _module_level_imports(tree: ast.Module) -> list[tuple[int, str]]:
    """(line, top-level module) of the imports that run when the module is imported: those not
    inside a function and not in a ``try`` whose handler catches ImportError."""
    found = []

    def visit(body: list[ast.stmt]) -> None:
        for node in body:
            if isinstance(node, ast.Import):
                found.extend((node.lineno, a.name.split(".")[0]) for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.append((node.lineno, node.module.split(".")[0]))
            elif isinstance(node, ast.Try):
                if not _guarded_by_import_error(node.handlers):
                    visit(node.body)
                visit(node.orelse + node.finalbody + [s for h in node.handlers for s in h.body])
            elif isinstance(node, (ast.If, ast.With, ast.ClassDef)):
                visit(node.body + getattr(node, "orelse", []))

    visit(tree.body)
    return found


def test_optional_imports_wait_until_they_are_needed():
    """MediaPipe, PyAV and Ray are optional (not declared, or an extra): no module of morf/ or
    studio/ imports them when it is imported itself, so every command that does not need them runs
    without them (and the ones that do say what to install)."""
    offenders = [f"{path.relative_to(REPO)}:{line}: import {name}"
                 for source in SOURCES for path in sorted((REPO / source).rglob("*.py"))
                 for line, name in _module_level_imports(parsed(path))
                 if name in GUARDED]
    assert not offenders, "imported at module level although optional:\n" + "\n".join(offenders)


@pytest.mark.parametrize("strict", ["0", "1"])
def test_an_import_skip_fails_in_a_strict_install(tmp_path, strict):
    """``pytest.importorskip`` of a missing module skips, and fails (in a test and for a whole file)
    under MORF_REQUIRE_DEPS: tests/conftest.py's guard, run on two throwaway test files."""
    import os
    import subprocess

    (tmp_path / "test_in_a_test.py").write_text("import pytest\n\ndef test_it():\n    pytest.importorskip('no_such_module_here')\n\n"
                                                "def test_other_skip():\n    pytest.skip('another reason')\n")
    (tmp_path / "test_a_file.py").write_text("import pytest\npytest.importorskip('no_such_module_here')\n\ndef test_it():\n    pass\n")
    env = {**os.environ, "PYTHONPATH": str(REPO), "MORF_REQUIRE_DEPS": strict, "MORF_REQUIRE_GL": "0"}
    outcomes = {}
    for name in ("test_in_a_test.py", "test_a_file.py"):
        r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "tests.conftest",
                            "--rootdir", str(tmp_path), name], cwd=tmp_path, env=env, capture_output=True, text=True,
                           timeout=120)
        outcomes[name] = r.stdout.strip().splitlines()[-1]
    if strict == "1":
        assert re.match(r"1 failed, 1 skipped", outcomes["test_in_a_test.py"]), outcomes
        assert re.match(r"1 error", outcomes["test_a_file.py"]), outcomes
    else:
        assert re.match(r"2 skipped", outcomes["test_in_a_test.py"]), outcomes
        assert re.match(r"1 skipped", outcomes["test_a_file.py"]), outcomes
