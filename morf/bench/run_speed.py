"""A trained run's playback speed, measured once per machine and kept beside the run.

Several sweeps often time the same run: the scenes of ``--auto-check`` that share a capture, a
point that resolves to the base's training (the automatic choice often does), a sweep grown
point by point. Exporting the avatar with its int8 calibration and timing it in a child process
is most of a small sweep's time, and the answer depends only on the trained avatar, the playback
size and frame count, the precision and the machine. So the first measurement is written to
``RUN/playback_speed/<precision>-<size>px-<frames>f.json`` with that identity, and later ones read
it back while the identity holds (a run trained further, another CPU, or a masked CPU class
measure again).
"""

from __future__ import annotations

import json
from pathlib import Path

SPEED_DIR = "playback_speed"


def speed_identity(run_dir: Path, size: int, frames: int, precision: str) -> dict:
    """What a stored measurement must match to be reused: the trained avatar file (size and
    modification time), the playback settings and the machine's CPU as the benchmarks record it."""
    from morf.bench.common import machine_info
    from morf.train.trained_avatar import AVATAR_FILE

    st = (Path(run_dir) / AVATAR_FILE).stat()
    machine = machine_info()
    return {"avatar_bytes": st.st_size, "avatar_mtime_ns": st.st_mtime_ns, "size": size, "frames": frames,
            "precision": precision, "cpu": machine["cpu"], "cores": machine["cores"],
            "cpuid_masked_to": machine["cpu_features"].get("cpuid_masked_to")}


def stored_speed_path(run_dir: Path, size: int, frames: int, precision: str) -> Path:
    return Path(run_dir) / SPEED_DIR / f"{precision}-{size}px-{frames}f.json"


def speed_of_run_once(run_dir, work: Path, size: int, frames: int, precision: str, body_model):
    """:func:`morf.bench.train_eval.speed_of_run`, reused from the run's folder when this run was
    already timed with these settings on this machine; (RunSpeed, reused)."""
    from morf.bench.train_eval import RunSpeed, speed_of_run
    from morf.io import atomic_write_json

    ident = speed_identity(run_dir, size, frames, precision)
    path = stored_speed_path(run_dir, size, frames, precision)
    if path.is_file():
        try:
            saved = json.loads(path.read_text())
            if saved.get("identity") == ident:
                return RunSpeed.from_dict(saved["speed"]), True
        except (ValueError, KeyError, TypeError):
            pass  # damaged or from an older layout: measured again and replaced below
    speed = speed_of_run(run_dir, work, size, frames, precision, body_model)
    atomic_write_json(path, {"identity": ident, "speed": speed.to_dict()})
    return speed, False
