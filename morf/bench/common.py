"""Helpers shared by the benchmarks: machine description and result writing."""

from __future__ import annotations

import os
import platform
import time
from pathlib import Path

from morf.io import atomic_write_json, atomic_write_text


def morf_command() -> list[str]:
    """The ``morf`` console script a user runs, as a command line: beside this interpreter in a
    virtual environment, else on PATH. Benchmarks that time or kill whole commands run it."""
    import shutil
    import sys

    from morf.errors import MorfError

    beside = Path(sys.executable).with_name("morf")
    command = str(beside) if beside.is_file() else shutil.which("morf")
    if command is None:
        raise MorfError("cannot find the 'morf' command (not beside this Python, not on PATH): install morf first")
    return [command]


def machine_info() -> dict:
    """What the numbers were measured on."""
    import torch

    info = {
        "cpu": platform.processor() or platform.machine(),
        "cores": os.cpu_count(),
        "torch_threads": torch.get_num_threads(),
        "cuda": torch.cuda.get_device_name(0) if torch.cuda.is_available() else None,
        "python": platform.python_version(),
        "torch": torch.__version__,
        "date": time.strftime("%Y-%m-%d %H:%M"),
    }
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    info["cpu"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    from morf.machine.features import cpu_summary

    info["cpu_features"] = cpu_summary()
    masked = info["cpu_features"].get("cpuid_masked_to")
    if masked:  # `morf bench --cpu-as CLASS`: never to be read as this CPU's own number
        info["cpu"] += f" with CPUID masked to the {masked} class (its kernels on this silicon)"
    return info


def host_loop_ms(repeats: int = 5) -> float:
    """The best of ``repeats`` timings (ms) of a fixed single-threaded Python loop: how fast this
    host runs right now, written beside benchmark numbers taken minutes apart on a shared machine
    (the same code's times move by a third there as the host's speed moves; lower is faster)."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        sum(range(2_000_000))
        best = min(best, time.perf_counter() - t0)
    return round(1000 * best, 1)


def cpu_ticks() -> tuple[int, int] | None:
    """(steal, all) ticks of this machine's CPUs so far (Linux /proc/stat; None elsewhere): the time
    the hypervisor gave the virtual CPUs to other guests, and all time. Between two readings, the
    steal share says how much of the host the benchmark did not get (multi-threaded work loses the
    most: a thread waits for the one that was stolen from)."""
    try:
        fields = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    except (OSError, ValueError):
        return None
    return (fields[7] if len(fields) > 7 else 0), sum(fields[:8])


def steal_share(before: tuple[int, int] | None, after: tuple[int, int] | None) -> float | None:
    """The share of CPU time stolen between two :func:`cpu_ticks` readings (None: unknown)."""
    if before is None or after is None or after[1] <= before[1]:
        return None
    return round((after[0] - before[0]) / (after[1] - before[1]), 4)


def markdown_table(rows: list[dict], columns: list[str], floatfmt: str = "{:.3g}") -> str:
    """A Markdown table of ``rows`` (dicts) with the given column order."""
    def fmt(v):
        if v is None:
            return "n/a"
        if isinstance(v, float):
            return floatfmt.format(v)
        return str(v)

    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(fmt(r.get(c)) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def write_results(out_dir: str | Path, name: str, result: dict, markdown: str) -> Path:
    """Write ``<name>.json`` and ``<name>.md`` into ``out_dir``; returns the JSON path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / f"{name}.json", result)
    atomic_write_text(out / f"{name}.md", markdown)
    return out / f"{name}.json"
