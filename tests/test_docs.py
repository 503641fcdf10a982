"""The README's and the getting-started page's Python runs as printed, and every relative link of the README and
of the documentation pages leads to a file that exists (the site's build, ``make docs``, checks them too)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
PAGES = sorted((ROOT / "docs").glob("*.md"))


def test_readme_links_resolve():
    for target in re.findall(r"\]\(([^)#:]+)\)", README):
        assert (ROOT / target).exists(), target


@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_doc_page_links_resolve(page):
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
    for target in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", text):
        assert (page.parent / target).exists(), f"{page.name} links to {target}"


def test_the_site_has_a_page_for_every_command():
    """The command-line reference is generated from the parser, one section per command."""
    sys.path.insert(0, str(ROOT / "docs" / "_hooks"))
    try:
        from cli_reference import MARKER, on_page_markdown
    finally:
        sys.path.pop(0)
    page = (ROOT / "docs" / "cli.md").read_text()
    assert MARKER in page
    text = on_page_markdown(page, None)
    for name in ("solve", "inverse", "sample", "workspace", "optimize", "reproduce", "compare", "accuracy",
                 "designs", "robot"):
        assert f"## `tdcr {name}`" in text and f"usage: tdcr {name}" in text


@pytest.mark.slow
def test_readme_python_tour_runs(tmp_path):
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert blocks, "the README has no Python block"
    blocks += re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "getting-started.md").read_text(), flags=re.S)
    script = tmp_path / "tour.py"
    script.write_text("\n".join(blocks))
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600,
                          check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "True" in proc.stdout
