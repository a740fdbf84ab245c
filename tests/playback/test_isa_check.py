"""tools/isa_check.py: the int8 graph under QEMU's emulation of an AVX2-only CPU (skipped without
qemu-user), or with this CPU's CPUID masked to the AVX2 class (skipped without CPUID faulting)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

TOOL = Path(__file__).resolve().parents[2] / "tools" / "isa_check.py"

pytestmark = pytest.mark.gl


@pytest.mark.skipif(shutil.which("qemu-x86_64") is None, reason="needs qemu-user")
def test_the_emulated_cpu_has_no_avx512_and_renders_the_same_image(tiny_avatar):
    out = subprocess.run([sys.executable, str(TOOL), str(tiny_avatar), "--frames", "1"], capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "other CPU: znver2 avx2 no avx512f no avx512vnni no amx-int8" in out.stdout
    agree = re.search(r"vs this CPU: ([0-9.inf]+) dB", out.stdout)
    assert agree is not None and float(agree.group(1)) > 40.0, out.stdout


def test_the_masked_cpu_takes_the_avx2_kernels_and_renders_the_same_image(tiny_avatar, tmp_path):
    from morf.machine.cpuid_mask import supported

    if supported() is not None or not (shutil.which("cc") or shutil.which("gcc")):
        pytest.skip("needs CPUID faulting and a C compiler")
    out = subprocess.run([sys.executable, str(TOOL), str(tiny_avatar), "--frames", "1", "--cpu-as", "avx2"],
                         capture_output=True, text=True, timeout=300,
                         env={**os.environ, "XDG_CACHE_HOME": str(tmp_path)})
    assert out.returncode == 0, out.stderr[-2000:]
    assert re.search(r"other CPU: \S+ avx2 no avx512f no avx512vnni no amx-int8", out.stdout), out.stdout
    agree = re.search(r"the avx2 class vs this CPU: ([0-9.inf]+) dB", out.stdout)
    assert agree is not None and float(agree.group(1)) > 40.0, out.stdout
