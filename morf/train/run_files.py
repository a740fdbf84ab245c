"""The files of a training run folder ``PROJECT/runs/<name>/``: their names, and the reading and
writing of the small ones. Torch-free, so the studio lists runs without loading the training stack.

Layout::

    config.json      the resolved TrainConfig (read back on resume)
    checkpoint.pt    latest training state (atomic; torch.save of state dicts and plain numbers)
    avatar.pt        the trained avatar for export: baked texture + renderer (written at the end)
    train.log        human-readable log lines (the header names the fits: "fits: <source>; ...")
    metrics.jsonl    one JSON object per logged step ({"step", "time_s", losses...})

:class:`RunFiles` is the one place that names these files and parses the small ones: config.json as
a plain dict, metrics.jsonl line by line (a line cut by a kill is skipped), the fits note of
train.log. :class:`morf.train.run_dir.RunDir` builds on it with what needs the training stack: the
config as a ``TrainConfig`` and the torch checkpoints. It is a module of its own rather than
``run_dir.py`` with lazy imports because ``TrainConfig`` itself imports torch (through the renderer
and warp configs), so reading a run's config there could never be torch-free.
"""

from __future__ import annotations

import json
import math
import re
import sys
import time
from pathlib import Path

CONFIG_FILE = "config.json"
CHECKPOINT_FILE = "checkpoint.pt"
AVATAR_FILE = "avatar.pt"
LOG_FILE = "train.log"
METRICS_FILE = "metrics.jsonl"
AUTO_SIZE_FILE = "auto_size.txt"  # why `--preset auto` chose the run's sizes
# Every file a run writes; `morf train --restart` deletes these and nothing else.
RUN_FILES = (CONFIG_FILE, CHECKPOINT_FILE, AVATAR_FILE, LOG_FILE, METRICS_FILE, AUTO_SIZE_FILE)

FITS_SOURCES = ("fits", "ground-truth")  # what the fits note of train.log may name
_FITS_NOTE = re.compile(r"\bfits: ([\w-]+);")


def read_metrics_file(path: str | Path) -> list[dict]:
    """The JSON objects of a metrics.jsonl, in order; [] when the file is absent. A line that is not
    JSON (the last one, cut by a kill) is skipped."""
    path = Path(path)
    if not path.is_file():
        return []
    out = []
    for line in path.read_text().splitlines():
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            continue  # a line cut by a kill
    return out


def last_step(rows: list) -> int:
    """The "step" of the last metrics row that has a usable one (a row without the key counts as 0);
    0 when there is none."""
    for row in reversed(rows):
        try:
            return int(row.get("step", 0))
        except (TypeError, ValueError, AttributeError):
            continue
    return 0


class RunFiles:
    """The file paths of one run folder and the reading and writing of its small files."""

    def __init__(self, root: str | Path):
        self.root = Path(root)

    config_path = property(lambda self: self.root / CONFIG_FILE)
    checkpoint_path = property(lambda self: self.root / CHECKPOINT_FILE)
    avatar_path = property(lambda self: self.root / AVATAR_FILE)
    log_path = property(lambda self: self.root / LOG_FILE)
    metrics_path = property(lambda self: self.root / METRICS_FILE)

    @property
    def has_checkpoint(self) -> bool:
        return self.checkpoint_path.is_file()

    @property
    def is_done(self) -> bool:
        return self.avatar_path.is_file()

    # ---- config.json ----------------------------------------------------------------------
    def read_config_dict(self) -> dict:
        """config.json as written (raises OSError when unreadable, json.JSONDecodeError when damaged)."""
        return json.loads(self.config_path.read_text())

    # ---- train.log ------------------------------------------------------------------------
    def log(self, line: str) -> None:
        self.root.mkdir(parents=True, exist_ok=True)
        with open(self.log_path, "a") as f:
            f.write(time.strftime("%Y-%m-%d %H:%M:%S ") + line + "\n")

    def fits_source(self) -> str:
        """The fits source the log's header names ("fits: <source>; frames cache: ..."), else "auto"."""
        if self.log_path.is_file():
            m = _FITS_NOTE.search(self.log_path.read_text(errors="replace"))
            if m and m.group(1) in FITS_SOURCES:
                return m.group(1)
        return "auto"

    # ---- metrics.jsonl --------------------------------------------------------------------
    def append_metrics(self, record: dict) -> None:
        clean = {k: (v if not isinstance(v, float) or math.isfinite(v) else None) for k, v in record.items()}
        with open(self.metrics_path, "a") as f:
            f.write(json.dumps(clean) + "\n")

    def read_metrics(self) -> list[dict]:
        return read_metrics_file(self.metrics_path)

    def last_step(self) -> int:
        """The last step metrics.jsonl recorded (0: none)."""
        return last_step(self.read_metrics())


def run_path(project, name: str) -> Path:
    """``PROJECT/runs/<name>`` for a name a user gave (a single folder name, else an InputError)."""
    from morf.io.names import check_name

    return Path(project.runs_dir) / check_name(name, "run name")


def is_run_name(name: str) -> bool:
    """Whether a folder name under runs/ can be a run (dot folders such as ``.cache`` are the project's own)."""
    return not name.startswith(".")


def clear_run(root: Path) -> list[str]:
    """Delete the files a run writes (:data:`RUN_FILES`, and temporaries of its atomic writes) from
    ``root``, then the folder when nothing else is left; returns the names of other files, which stay."""
    root = Path(root)
    if not root.is_dir():
        return []
    kept = []
    for p in root.iterdir():
        ours = p.name in RUN_FILES or any(p.name.startswith(f".{n}.") for n in RUN_FILES)
        if ours and not p.is_dir():
            p.unlink()
        else:
            kept.append(p.name)
    if not kept:
        root.rmdir()
    return sorted(kept)


def restart_run(root: Path) -> None:
    """``morf train --restart``: delete what the run wrote (and only that), saying what was left."""
    kept = clear_run(root)
    if kept:
        print(f"note: {root} also holds files training did not write ({', '.join(kept[:3])}); they are kept",
              file=sys.stderr)


def finished_run_dirs(project) -> list[Path]:
    """The run folders of ``project`` holding a trained avatar (``avatar.pt``), oldest avatar first."""
    root = Path(project.runs_dir)
    if not root.is_dir():
        return []
    done = [RunFiles(d) for d in root.iterdir() if is_run_name(d.name) and RunFiles(d).is_done]
    return [run.root for run in sorted(done, key=lambda run: run.avatar_path.stat().st_mtime)]
