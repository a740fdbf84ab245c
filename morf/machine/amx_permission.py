"""Whether this process may use AMX, and refusing it for a measurement (Linux x86-64).

AMX is in the CPU's flags, but on Linux a process must also ask the kernel for the tile state
(``arch_prctl(ARCH_REQ_XCOMP_PERM, XFEATURE_XTILEDATA)``) before its first tile instruction;
onnxruntime's and oneDNN's kernels ask and fall back to AVX-512 / AVX2 when the kernel says no
(older kernels, some containers). :func:`refuse_amx` makes the kernel say no to this process
and its children (a seccomp filter on that one request), so ``morf bench render --no-amx``
measures on an AMX CPU what the same CPU gets without it.
"""

from __future__ import annotations

import ctypes
import functools
import platform
import struct
import sys

from morf.errors import InputError

SYS_ARCH_PRCTL = 158  # x86-64
ARCH_GET_XCOMP_PERM = 0x1022
ARCH_REQ_XCOMP_PERM = 0x1023
XFEATURE_XTILEDATA = 18
_AUDIT_ARCH_X86_64 = 0xC000003E
_PR_SET_NO_NEW_PRIVS, _PR_SET_SECCOMP, _SECCOMP_MODE_FILTER = 38, 22, 2
_SECCOMP_RET_ALLOW, _SECCOMP_RET_ERRNO, _EPERM = 0x7FFF0000, 0x00050000, 1


def _linux_x86_64() -> bool:
    return sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")


def _libc():
    return ctypes.CDLL(None, use_errno=True)


def _tiles_permitted() -> bool:
    """The tile state is already granted to this process (asks nothing of the kernel)."""
    mask = ctypes.c_uint64(0)
    if _libc().syscall(SYS_ARCH_PRCTL, ARCH_GET_XCOMP_PERM, ctypes.byref(mask)) != 0:
        return False
    return bool(mask.value & (1 << XFEATURE_XTILEDATA))


@functools.lru_cache(maxsize=1)
def amx_permitted() -> bool:
    """True when the kernel grants this process the AMX tile state (asking for it, as the
    libraries do on their first AMX kernel). False off Linux x86-64 or when refused."""
    if not _linux_x86_64():
        return False
    try:
        return _libc().syscall(SYS_ARCH_PRCTL, ARCH_REQ_XCOMP_PERM, XFEATURE_XTILEDATA) == 0
    except (OSError, AttributeError):
        return False


def refuse_amx() -> None:
    """From now on the kernel refuses AMX to this process and every process it starts.

    Call it before onnxruntime or torch is imported: a grant already made cannot be taken back.
    Raises :class:`InputError` where that is not possible (not Linux x86-64, AMX already granted,
    seccomp unavailable)."""
    if not _linux_x86_64():
        raise InputError("refusing AMX needs Linux on x86-64")
    if _tiles_permitted():
        raise InputError("AMX was already granted to this process (onnxruntime or torch was loaded first)")

    def ins(code: int, jt: int, jf: int, k: int) -> bytes:  # one classic-BPF instruction
        return struct.pack("HBBI", code, jt, jf, k)

    ld, jeq, ret = 0x20, 0x15, 0x06  # BPF_LD|BPF_W|BPF_ABS, BPF_JMP|BPF_JEQ|BPF_K, BPF_RET|BPF_K
    # seccomp_data: nr at 0, arch at 4, args[0] (low word) at 16
    program = b"".join([
        ins(ld, 0, 0, 4), ins(jeq, 0, 5, _AUDIT_ARCH_X86_64),
        ins(ld, 0, 0, 0), ins(jeq, 0, 3, SYS_ARCH_PRCTL),
        ins(ld, 0, 0, 16), ins(jeq, 0, 1, ARCH_REQ_XCOMP_PERM),
        ins(ret, 0, 0, _SECCOMP_RET_ERRNO | _EPERM),
        ins(ret, 0, 0, _SECCOMP_RET_ALLOW)])

    class _Program(ctypes.Structure):
        _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_void_p)]

    code = ctypes.create_string_buffer(program)
    prog = _Program(len(program) // 8, ctypes.addressof(code))
    libc = _libc()
    if libc.prctl(_PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 or \
            libc.prctl(_PR_SET_SECCOMP, _SECCOMP_MODE_FILTER, ctypes.byref(prog), 0, 0) != 0:
        raise InputError(f"could not install the seccomp filter that refuses AMX (errno {ctypes.get_errno()})")
    amx_permitted.cache_clear()
