"""What this CPU can do natively, read from the machine instead of assumed.

Numbers in the docs come from different x86 CPUs (AMD or Intel, with or without AMX, native
bfloat16 or VNNI); code that picks a faster path asks here first.
"""

from __future__ import annotations

import functools

from morf.machine.amx_permission import amx_permitted
from morf.machine.cpuid_mask import CLASSES, active_class
from morf.machine.flags import host_flags

# /proc/cpuinfo flags that matter for our kernels
FLAGS_OF_INTEREST = ("avx2", "fma", "avx512f", "avx512_vnni", "avx_vnni", "avx512_bf16", "amx_bf16", "amx_int8",
                     "amx_tile")


@functools.lru_cache(maxsize=1)
def cpu_flags() -> frozenset[str]:
    """The CPU's feature flags (Linux ``/proc/cpuinfo``; empty where it cannot be read), less
    those a CPUID mask hides from this process (``morf bench --cpu-as``)."""
    flags = host_flags()
    masked = active_class()
    return flags - set(CLASSES[masked][1]) if masked else flags


def native_bf16() -> bool:
    """True when the CPU computes bfloat16 in hardware (AMX-BF16 or AVX512-BF16).

    Without it, bfloat16 autocast on the CPU is emulated through float32 conversions: a 2-core
    Xeon with AVX-512 VNNI but neither flag trained 1.8x slower with it on.
    """
    flags = cpu_flags()
    return "amx_bf16" in flags or "avx512_bf16" in flags


def cpu_summary() -> dict:
    """The flags of :data:`FLAGS_OF_INTEREST` this CPU has, for benchmark records and logs, and
    whether the kernel lets this process use AMX (``amx_usable``; a CPU flag is not enough)."""
    flags = cpu_flags()
    has_amx = "amx_tile" in flags
    summary = {"flags": [f for f in FLAGS_OF_INTEREST if f in flags], "native_bf16": native_bf16(),
               "amx_usable": bool(has_amx and amx_permitted())}
    masked = active_class()  # the smaller CPU class of ``morf bench --cpu-as``, or None
    if masked:
        summary["cpuid_masked_to"] = masked
    return summary
