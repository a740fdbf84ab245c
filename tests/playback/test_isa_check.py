"""tools/isa_check.py: the int8 graph under QEMU's emulation of an AVX2-only CPU (skipped without
qemu-user)."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

TOOL = Path(__file__).resolve().parents[2] / "tools" / "isa_check.py"

pytestmark = [pytest.mark.gl,
              pytest.mark.skipif(shutil.which("qemu-x86_64") is None, reason="needs qemu-user")]


def test_the_emulated_cpu_has_no_avx512_and_renders_the_same_image(tiny_avatar):
    out = subprocess.run([sys.executable, str(TOOL), str(tiny_avatar), "--frames", "1"], capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "emulated CPU: znver2 avx2 no avx512f no avx512vnni no amx-int8" in out.stdout
    agree = re.search(r"vs this CPU: ([0-9.inf]+) dB", out.stdout)
    assert agree is not None and float(agree.group(1)) > 40.0, out.stdout
