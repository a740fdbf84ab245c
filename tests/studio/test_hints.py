"""Every command the studio suggests to the user works when pasted.

Each quoted ``'morf ...'`` / ``'morf-studio ...'`` in a string the studio shows or prints (not
docstrings, not comments) is found in the source, its placeholders (PROJECT, FILE, ...) are filled
in, and the real command-line parser must accept it: a wrong argument order, a missing required
option or a command that does not exist fails here. Each distinct command also runs with
``--help`` through the installed entry point, as a user would.
"""

from __future__ import annotations

import ast
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from tests.test_layers import _docstrings  # the same walk: which string constants are docstrings

STUDIO = Path(__file__).resolve().parents[2] / "studio"
QUOTED = re.compile(r"'((?:morf|morf-studio) [^']+)'")
# placeholder words in suggested commands -> what a user would type there
PLACEHOLDERS = {"PROJECT": "capture", "NEWFOLDER": "new-capture", "FILE": "clip.mp4", "VIDEO": "clip.mp4",
                "N": "3", "PNG": "shot.png", "DIR": "avatar", "FOLDER": "out", "RUN": "run1", "NAME": "run1"}


def suggested_commands() -> list[tuple[str, str]]:
    """(file:line, command) of every quoted command in the studio's strings (implicit
    concatenation joined, as Python joins it; the literal parts of f-strings too)."""
    found = []
    for path in sorted(STUDIO.rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        skip = _docstrings(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
                for m in QUOTED.finditer(node.value):
                    found.append((f"{path.relative_to(STUDIO.parent)}:{node.lineno}", m.group(1)))
    return found


def fill(command: str) -> list[str]:
    return [PLACEHOLDERS.get(w, w) for w in shlex.split(command)]


def parse(words: list[str]) -> None:
    """Parse ``words`` with the real parser of ``morf`` or ``morf-studio``; SystemExit on a usage error."""
    if words[0] == "morf":
        from morf.cli.main import build_parser

        build_parser().parse_args(words[1:])
    else:
        from studio.app import build_parser

        build_parser().parse_args(words[1:])


COMMANDS = suggested_commands()


def test_the_studio_suggests_commands_and_the_old_wrong_one_is_gone():
    texts = [c for _, c in COMMANDS]
    assert "morf run PROJECT --video FILE" in texts  # the start screen's way from a video
    assert not any(c.startswith("morf ingest VIDEO") for c in texts)


@pytest.mark.parametrize("where,command", COMMANDS, ids=[c for _, c in COMMANDS])
def test_each_suggested_command_parses(where, command, capsys):
    try:
        parse(fill(command))
    except SystemExit as e:
        err = capsys.readouterr().err.strip().splitlines()
        pytest.fail(f"{where}: '{command}' does not work as written: {err[-1] if err else e}")


def test_the_parser_check_catches_a_wrong_argument_order(capsys):
    with pytest.raises(SystemExit):
        parse(fill("morf ingest VIDEO PROJECT"))  # the hint the start screen used to give
    with pytest.raises(SystemExit):
        parse(fill("morf bench render"))  # --out missing


@pytest.mark.parametrize("words", sorted({tuple(w for w in shlex.split(c) if not w.isupper() and not w.startswith("-"))
                                          for _, c in COMMANDS}))
def test_each_suggested_command_runs_with_help(words):
    """The command exists in the installed program (its sub-command words, then --help)."""
    exe = Path(sys.executable).parent / words[0]
    if not exe.is_file():
        pytest.skip(f"{words[0]} is not installed next to {sys.executable}")
    r = subprocess.run([str(exe), *words[1:], "--help"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "usage:" in r.stdout and "Traceback" not in r.stderr
