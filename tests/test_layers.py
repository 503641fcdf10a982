"""Layering: the core imports neither plotting nor the command line."""

from __future__ import annotations

import subprocess
import sys


def test_core_import_is_light():
    code = (
        "import sys, pytdcr; "
        "bad = [m for m in ('matplotlib', 'pytdcr.cli', 'pytdcr.plotting', 'pymoo') if m in sys.modules]; "
        "print(','.join(bad))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""
