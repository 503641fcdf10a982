"""The README's and every how-to page's Python runs as printed, and every relative link of the README and of the
documentation pages leads to a file that exists (the site's build, ``make docs``, checks them too).

Each page's ```python blocks run in order as one script, in one subprocess per page, in a scratch folder (so a
later block may use a name an earlier block made). A block that is shown but not meant to run (a fragment, or one
that needs files or minutes the tests do not have) is fenced as ```text, or as ```python with the marker
``# doc: no-run`` on its first line; use the marker sparingly: every block that can run should.
"""

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
                 "designs", "calibrate", "robot"):
        assert f"## `tdcr {name}`" in text and f"usage: tdcr {name}" in text


#: the how-to pages whose Python runs as printed (each in one subprocess)
HOW_TO = ("getting-started.md", "robot.md", "solve.md", "choose-model.md", "inverse.md", "workspace.md",
          "designs.md", "calibrate.md", "explore.md", "run-files.md")
#: a ```python block with this on its first line is shown, not run
NO_RUN = "# doc: no-run"


def python_blocks(text: str) -> list[str]:
    """The ```python blocks of a Markdown text, in order, less those marked :data:`NO_RUN`."""
    blocks = re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)
    return [b for b in blocks if not b.startswith(NO_RUN)]


def run_blocks(blocks: list[str], folder: Path) -> subprocess.CompletedProcess:
    script = folder / "page.py"
    script.write_text("\n".join(blocks))
    return subprocess.run([sys.executable, str(script)], cwd=folder, capture_output=True, text=True, timeout=900,
                          check=False)


def test_python_blocks_are_found():
    """The block finder keeps a page's blocks in order and leaves out the marked ones."""
    text = "a\n```python\nx = 1\n```\n```python\n# doc: no-run\ny\n```\n```text\nz\n```\n```python\nprint(x)\n```\n"
    assert python_blocks(text) == ["x = 1\n", "print(x)\n"]


@pytest.mark.slow
def test_readme_python_tour_runs(tmp_path):
    blocks = python_blocks(README)
    assert blocks, "the README has no Python block"
    proc = run_blocks(blocks, tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "True" in proc.stdout


@pytest.mark.slow
@pytest.mark.parametrize("page", HOW_TO)
def test_how_to_python_runs(page, tmp_path):
    """Every Python block of a how-to page runs as printed (a page still a stub has none and is skipped)."""
    blocks = python_blocks((ROOT / "docs" / page).read_text())
    if not blocks:
        pytest.skip(f"{page} has no Python block yet")
    proc = run_blocks(blocks, tmp_path)
    assert proc.returncode == 0, f"{page}:\n{proc.stderr[-3000:]}"
