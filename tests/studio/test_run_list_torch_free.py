"""The Training panel's run list reads run folders without importing torch."""

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_run_list_imports_no_torch():
    script = textwrap.dedent("""
        import sys
        import morf.train.run_files, studio.run_list
        assert "torch" not in sys.modules, "torch was imported"
    """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
