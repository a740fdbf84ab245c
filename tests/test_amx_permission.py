"""Refusing AMX to a process (``morf bench render --no-amx``) and reporting it."""

from __future__ import annotations

import platform
import subprocess
import sys
import textwrap

import pytest

from morf.bench.render import cpu_report

linux_x86_64 = pytest.mark.skipif(not (sys.platform.startswith("linux") and platform.machine() == "x86_64"),
                                  reason="AMX permission is a Linux x86-64 matter")


def _child(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=120)


@linux_x86_64
def test_a_refused_process_and_its_children_cannot_get_amx_and_int8_still_computes():
    r = _child("""
        import ctypes, subprocess, sys
        import numpy as np
        from morf.machine.amx_permission import ARCH_REQ_XCOMP_PERM, SYS_ARCH_PRCTL, XFEATURE_XTILEDATA, amx_permitted, refuse_amx
        refuse_amx()
        libc = ctypes.CDLL(None, use_errno=True)
        assert libc.syscall(SYS_ARCH_PRCTL, ARCH_REQ_XCOMP_PERM, XFEATURE_XTILEDATA) == -1
        assert ctypes.get_errno() == 1  # EPERM: the filter's answer, on any x86-64 CPU
        assert not amx_permitted()
        child = subprocess.run([sys.executable, "-c", "from morf.machine.amx_permission import amx_permitted; "
                                "print(amx_permitted())"], capture_output=True, text=True)
        assert child.stdout.strip() == "False", child.stderr
        import onnx, onnxruntime as ort
        from onnx import TensorProto, helper
        g = helper.make_graph([helper.make_node("MatMulInteger", ["a", "b"], ["y"])], "g",
                              [helper.make_tensor_value_info("a", TensorProto.UINT8, [64, 256]),
                               helper.make_tensor_value_info("b", TensorProto.INT8, [256, 64])],
                              [helper.make_tensor_value_info("y", TensorProto.INT32, [64, 64])])
        m = helper.make_model(g, opset_imports=[helper.make_opsetid("", 17)])
        rng = np.random.default_rng(0)
        a, b = rng.integers(0, 256, (64, 256)).astype(np.uint8), rng.integers(-128, 128, (256, 64)).astype(np.int8)
        y = ort.InferenceSession(m.SerializeToString(), providers=["CPUExecutionProvider"]).run(None, {"a": a, "b": b})[0]
        assert np.array_equal(y, a.astype(np.int64) @ b.astype(np.int64))
        print("ok")
    """)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stderr


@linux_x86_64
def test_amx_already_granted_cannot_be_refused():
    r = _child("""
        from morf.machine.amx_permission import amx_permitted, refuse_amx
        from morf.errors import InputError
        if not amx_permitted():
            print("no amx")
        else:
            try:
                refuse_amx()
            except InputError as e:
                print("refused:", e)
    """)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(("no amx", "refused: AMX was already granted")), r.stdout


def test_the_cpu_line_says_when_the_kernel_refused_amx():
    flags = {"flags": ["avx2", "avx512_vnni", "amx_int8", "amx_tile"]}
    assert "AMX yes" in cpu_report("X", 2, {**flags, "amx_usable": True})
    assert "AMX refused" in cpu_report("X", 2, {**flags, "amx_usable": False})
    assert "AMX yes" in cpu_report("X", 2, flags)  # a record from before the check: the flags alone
    assert "AMX no" in cpu_report("X", 2, {"flags": ["avx2"], "amx_usable": False})
