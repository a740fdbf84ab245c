"""The CPU's feature flags as the operating system lists them, before any CPUID mask.

The bottom of :mod:`morf.machine`: :mod:`~morf.machine.cpuid_mask` asks it whether CPUID
faulting is offered, :mod:`~morf.machine.features` takes the flags a mask hides away from it.
"""

from __future__ import annotations

def host_flags() -> frozenset[str]:
    """The ``flags`` line of Linux ``/proc/cpuinfo`` (empty where it cannot be read); read each
    time (:func:`morf.machine.features.cpu_flags` keeps what this process sees)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return frozenset(line.split(":", 1)[1].split())
    except OSError:
        pass
    return frozenset()
