"""Benchmarks as a smaller x86 CPU class would run them, on this CPU: ``morf bench --cpu-as CLASS ...``.

onnxruntime, numba (LLVM) and llvmpipe choose their kernels from the CPUID instruction. On Linux
with a CPU that has ``cpuid_fault``, ``cpuid_mask.c`` (compiled here with the system's C compiler
and loaded with ``LD_PRELOAD``) makes CPUID trap and answers it without the features the chosen
class lacks, in the benchmark and every process it starts. The kernels are then that class's,
the silicon (clock, caches, the cores' width) stays this one's: a measure of what the code paths
cost, not of another CPU's speed.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from morf.errors import InputError
from morf.machine.flags import host_flags

# class -> (what it stands for, the /proc/cpuinfo flags it lacks that morf.machine.features reports)
CLASSES = {
    "avx2": ("AVX2 + FMA only: no AVX-512, no VNNI, no AMX (Intel Haswell to Comet Lake, AMD Zen 2)",
             ("avx512f", "avx512_vnni", "avx_vnni", "avx512_bf16", "amx_bf16", "amx_int8", "amx_tile")),
    "avx512-vnni": ("AVX-512 with VNNI, no AMX, no native bf16 (Intel Cascade Lake / Ice Lake)",
                    ("avx_vnni", "avx512_bf16", "amx_bf16", "amx_int8", "amx_tile")),
}
_LEVEL_NAMES = {1: "avx2", 2: "avx512-vnni"}  # morf_cpuid_mask_level in cpuid_mask.c
ENV = "MORF_CPUID_MASK"
SOURCE = Path(__file__).with_name("cpuid_mask.c")


def active_class() -> str | None:
    """The class this process's CPUID answers as, or None when it is not masked."""
    try:
        level = ctypes.c_int.in_dll(ctypes.CDLL(None), "morf_cpuid_mask_level").value
    except (ValueError, OSError):
        return None
    return _LEVEL_NAMES.get(level)


def answered_cpuids() -> int:
    """How many CPUID instructions the mask answered in this process (0 when not masked)."""
    try:
        return int(ctypes.c_ulong.in_dll(ctypes.CDLL(None), "morf_cpuid_mask_faults").value)
    except (ValueError, OSError):
        return 0


def _cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "morf"


def build_shim(cache: Path | None = None) -> Path:
    """The compiled ``cpuid_mask.c`` (built once per source version, written atomically)."""
    source = SOURCE.read_bytes()
    out_dir = cache or _cache_dir()
    target = out_dir / f"cpuid_mask-{hashlib.sha256(source).hexdigest()[:12]}.so"
    if target.exists():
        return target
    cc = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc") or shutil.which("clang")
    if not cc:
        raise InputError("--cpu-as needs a C compiler to build its CPUID shim (install gcc, or set CC)")
    out_dir.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".so", dir=out_dir)
    os.close(fd)
    try:
        r = subprocess.run([cc, "-O2", "-shared", "-fPIC", "-o", tmp, str(SOURCE), "-ldl"], capture_output=True,
                           text=True)
        if r.returncode != 0:
            raise InputError(f"--cpu-as: building the CPUID shim failed:\n{r.stderr.strip()}")
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return target


def supported() -> str | None:
    """None when this machine can mask CPUID, else why not."""
    if not sys.platform.startswith("linux"):
        return "CPUID faulting is a Linux feature"
    if "cpuid_fault" not in host_flags():
        return "this CPU (or its hypervisor) does not offer CPUID faulting ('cpuid_fault' is not in /proc/cpuinfo)"
    return None


def masked_environ(cpu_class: str) -> dict[str, str]:
    """This process's environment with the shim preloaded for ``cpu_class``: a process started
    with it runs as that class. Raises InputError where the class is unknown or this machine
    cannot mask CPUID."""
    if cpu_class not in CLASSES:
        raise InputError(f"--cpu-as: unknown CPU class {cpu_class!r}; choose from {', '.join(CLASSES)}")
    why = supported()
    if why:
        raise InputError(f"--cpu-as {cpu_class}: {why}")
    env = dict(os.environ)
    env[ENV] = cpu_class
    env["LD_PRELOAD"] = " ".join(p for p in (str(build_shim()), env.get("LD_PRELOAD", "")) if p)
    return env


def run_as(cpu_class: str, argv: list[str] | None = None) -> None:
    """Make this command run as ``cpu_class``: returns at once when it already does, else
    replaces this process with the same command under the shim (never returns then)."""
    current = active_class()
    if current == cpu_class:
        return
    if os.environ.get(ENV) == cpu_class:  # the shim was loaded, yet the kernel refused faulting
        raise InputError(f"--cpu-as {cpu_class}: the kernel refused CPUID faulting to this process")
    env = masked_environ(cpu_class)
    sys.stdout.flush()
    sys.stderr.flush()
    args = argv if argv is not None else sys.orig_argv  # the interpreter's own command line, "-m" included
    os.execve(sys.executable, [sys.executable, *args[1:]], env)
