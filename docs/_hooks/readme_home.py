"""mkdocs hook: the site's home page (``index.md``) is the README, its links made relative to ``docs/``.

``index.md`` holds the marker ``<!-- readme -->``; at build time it becomes the README, so the landing page and
the site's home never drift apart.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

MARKER = "<!-- readme -->"
README = Path(__file__).resolve().parents[2] / "README.md"


def home_markdown(readme: str) -> str:
    """The README as the site's home: links into ``docs/`` made relative to it."""
    text = readme.replace("[docs/](docs/)", "the repository's `docs/` folder")
    return text.replace("](docs/", "](")


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    """Replace the marker of ``index.md`` with the README."""
    if MARKER not in markdown:
        return markdown
    return markdown.replace(MARKER, home_markdown(README.read_text(encoding="utf-8")))
