"""Running as a smaller CPU class through CPUID faulting (``morf bench --cpu-as CLASS``)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap

import pytest

from morf.machine.features import cpu_flags
from morf.machine.cpuid_mask import CLASSES, supported

needs_faulting = pytest.mark.skipif(supported() is not None or not (shutil.which("cc") or shutil.which("gcc")),
                                    reason="needs Linux CPUID faulting (cpuid_fault) and a C compiler")


def _masked(code: str, cpu_class: str, tmp_path, timeout=120) -> subprocess.CompletedProcess:
    """``code`` run by a Python that first re-runs itself under the mask, as ``morf bench --cpu-as`` does."""
    prologue = f"from morf.machine.cpuid_mask import run_as\nrun_as({cpu_class!r})\n"
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}
    return subprocess.run([sys.executable, "-c", prologue + textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=timeout, env=env)


CHECK = """
    import llvmlite.binding as llvm
    import numpy as np, onnxruntime as ort
    from onnx import TensorProto, helper
    from morf.machine.cpuid_mask import active_class, answered_cpuids
    from morf.machine.features import cpu_summary
    feats = llvm.get_host_cpu_features()
    print("class", active_class(), "avx512f", feats.get("avx512f", False), "avx512vnni", feats.get("avx512vnni", False),
          "amx", feats.get("amx-int8", False), "avx2", feats.get("avx2", False))
    print("summary", sorted(cpu_summary()["flags"]), cpu_summary().get("cpuid_masked_to"))
    # an int8 convolution, the renderer's kernel, run by the masked class's kernels
    x_info = helper.make_tensor_value_info("x", TensorProto.UINT8, [1, 16, 12, 12])
    w_info = helper.make_tensor_value_info("w", TensorProto.INT8, [8, 16, 3, 3])
    y_info = helper.make_tensor_value_info("y", TensorProto.INT32, [1, 8, 10, 10])
    conv = helper.make_graph([helper.make_node("ConvInteger", ["x", "w"], ["y"])], "conv", [x_info, w_info], [y_info])
    sess = ort.InferenceSession(helper.make_model(conv, opset_imports=[helper.make_opsetid("", 17)]).SerializeToString(),
                                providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    x, w = rng.integers(0, 128, (1, 16, 12, 12)).astype(np.uint8), rng.integers(-64, 64, (8, 16, 3, 3)).astype(np.int8)
    y = sess.run(None, {"x": x, "w": w})[0]
    patches = np.lib.stride_tricks.sliding_window_view(x[0].astype(np.int64), (3, 3), axis=(1, 2))  # 16,10,10,3,3
    assert np.array_equal(y[0], np.einsum("cijkl,ockl->oij", patches, w.astype(np.int64)))
    assert answered_cpuids() > 0
    print("ok")
"""


@needs_faulting
def test_avx2_class_hides_avx512_vnni_and_amx_from_llvm_onnxruntime_and_the_records(tmp_path):
    r = _masked(CHECK, "avx2", tmp_path)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stderr
    assert "class avx2 avx512f False avx512vnni False amx False avx2 True" in r.stdout
    hidden = set(CLASSES["avx2"][1])
    summary = next(line for line in r.stdout.splitlines() if line.startswith("summary"))
    assert "cpuid_masked_to" not in summary and summary.endswith("avx2")
    assert not any(f"'{f}'" in summary for f in hidden) and "'avx2'" in summary


@needs_faulting
def test_avx512_vnni_class_keeps_avx512_and_drops_amx(tmp_path):
    if "avx512_vnni" not in cpu_flags():
        pytest.skip("this CPU has no AVX-512 VNNI to keep")
    r = _masked(CHECK, "avx512-vnni", tmp_path)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stderr
    assert "class avx512-vnni avx512f True avx512vnni True amx False" in r.stdout


@needs_faulting
def test_a_real_segfault_still_reaches_the_programs_handler_or_kills_the_process(tmp_path):
    # Python's faulthandler installs its SIGSEGV handler after the mask's: it must still report the crash
    r = _masked("""
        import ctypes, faulthandler
        faulthandler.enable()
        import llvmlite.binding as llvm
        llvm.get_host_cpu_features()  # CPUID after the program's handler went in: still answered
        print("masked", flush=True)
        ctypes.string_at(0)
    """, "avx2", tmp_path)
    assert "masked" in r.stdout and r.returncode == -11, (r.returncode, r.stderr)
    assert "Segmentation fault" in r.stderr
    r = _masked("import ctypes\nprint('masked', flush=True)\nctypes.string_at(0)", "avx2", tmp_path)
    assert "masked" in r.stdout and r.returncode == -11, (r.returncode, r.stderr)


def test_an_unknown_class_or_a_machine_without_faulting_is_a_clear_error(tmp_path, monkeypatch):
    from morf.machine.cpuid_mask import run_as
    from morf.errors import InputError

    with pytest.raises(InputError, match="unknown CPU class 'avx9'"):
        run_as("avx9")
    monkeypatch.setattr("morf.machine.cpuid_mask.supported", lambda: "no CPUID faulting here")
    with pytest.raises(InputError, match="--cpu-as avx2: no CPUID faulting here"):
        run_as("avx2")


@needs_faulting
def test_morf_bench_render_as_an_avx2_cpu_records_the_class(tmp_path, tiny_avatar):
    """The records say which class the kernels were; an avatar exported beforehand is played (the
    benchmark's own synthetic avatars, trained and exported under the mask, took two minutes)."""
    out = tmp_path / "r"
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}
    cli = "import sys; from morf.cli.main import main; sys.exit(main())"  # what the `morf` script runs
    r = subprocess.run([sys.executable, "-c", cli, "bench", "--cpu-as", "avx2", "render", "--size", "128",
                        "--frames", "8", "--no-variants", "--avatar", str(tiny_avatar), "--out", str(out)], capture_output=True, text=True,
                       timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    rec = json.loads((out / "render.json").read_text())
    assert rec["cpu_features"]["cpuid_masked_to"] == "avx2"
    assert "avx512f" not in rec["cpu_features"]["flags"] and "amx_int8" not in rec["cpu_features"]["flags"]
    assert rec["command"].startswith("morf bench --cpu-as avx2 render")
    assert rec["machine"]["cpu"].endswith("with CPUID masked to the avx2 class (its kernels on this silicon)")
    md = (out / "render.md").read_text()
    assert "with CPUID masked to the avx2 class (its kernels on this silicon)" in md and "AMX no" in md
