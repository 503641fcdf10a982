"""mkdocs hook: the command-line reference page (``cli.md``) filled from the ``tdcr`` parser itself.

The page holds the marker ``<!-- tdcr-commands -->``; at build time it becomes every command's ``--help`` text,
so the reference never drifts from the options.
"""

from __future__ import annotations

import argparse
import os
from typing import Any

MARKER = "<!-- tdcr-commands -->"


def _commands() -> list[tuple[str, str]]:
    """(name, help text) of ``tdcr`` and of each of its commands, as argparse prints them (80 columns)."""
    os.environ["COLUMNS"] = "100"
    from pytdcr.cli import build_parser

    parser = build_parser()
    out = [("tdcr", parser.format_help())]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out.append((f"tdcr {name}", sub.format_help()))
    return out


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    """Replace the marker of ``cli.md`` with one section per command."""
    if MARKER not in markdown:
        return markdown
    parts = []
    for name, text in _commands():
        parts.append(f"## `{name}`\n\n```text\n{text.rstrip()}\n```\n")
    return markdown.replace(MARKER, "\n".join(parts))
