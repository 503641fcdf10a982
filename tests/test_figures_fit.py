"""Figures that fit (issue 29, item 3): every figure the project writes, and every one it ships, keeps its text
and artists inside the canvas. A figure saved with matplotlib's padding has a ring of background pixels at its
edge; anything clipped (a label, a tick, a legend) crosses that ring."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
WRENCH = ["--tip-force=0.1,0.1,-0.1", "--tip-moment=-0.1,0.1,0.1"]


def crossing_pixels(path: Path) -> int:
    """How many pixels of the outermost ring of the image differ from its corner (the background)."""
    a = mpimg.imread(path)
    a = a[..., None] if a.ndim == 2 else a
    ring = np.concatenate([a[0], a[-1], a[:, 0], a[:, -1]])
    return int(np.any(np.abs(ring - a[0, 0]) > 1e-3, axis=-1).sum())


def test_a_clipped_figure_is_caught(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(3, 2))
    ax.set_ylabel("a label that the edge cuts")
    fig.savefig(tmp_path / "fits.png", bbox_inches="tight", pad_inches=0.1)
    fig.subplots_adjust(left=0.0)  # the axes at the very edge: the label and ticks are cut off
    fig.savefig(tmp_path / "cut.png")
    plt.close(fig)
    assert crossing_pixels(tmp_path / "fits.png") == 0
    assert crossing_pixels(tmp_path / "cut.png") > 0


SHIPPED = sorted((ROOT / "docs").rglob("*.png"))


@pytest.mark.parametrize("path", SHIPPED, ids=[p.relative_to(ROOT).as_posix() for p in SHIPPED])
def test_every_shipped_figure_fits(path):
    assert crossing_pixels(path) == 0, f"{path.name}: something crosses the figure's edge"


def _run(args: list[str]) -> int:
    from pytdcr.cli import main

    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        return main(args)


@pytest.mark.slow
def test_every_figure_the_commands_write_fits(tmp_path):
    runs = {
        "solve": ["solve", "--tensions", "4,0,0,0,2,0,0,0", *WRENCH, "--plot", str(tmp_path / "solve" / "robot.png")],
        "sample": ["sample", "--n", "40", "--seed", "3", *WRENCH, "--out", str(tmp_path / "sample")],
        "optimize": ["optimize", "--pop", "10", "--max-gen", "2", "--seed", "1", *WRENCH, "--out",
                     str(tmp_path / "optimize")],
        "workspace": ["workspace", "--n", "80", "--seed", "5", "--directions", "4", "--budget", "400", *WRENCH,
                      "--out", str(tmp_path / "workspace")],
        "compare": ["compare", "--n", "4", "--seed", "2", "--models", "pcc,pcc2", "--out", str(tmp_path / "compare")],
        "designs": ["designs", str(ROOT / "examples" / "design_study_small.toml"), "--workers", "2", "--out",
                    str(tmp_path / "designs")],
    }
    for name, args in runs.items():
        assert _run(args) in (0, 1), name
    figures = sorted(tmp_path.rglob("*.png"))
    assert {p.relative_to(tmp_path).parts[0] for p in figures} == set(runs)
    clipped = {p.relative_to(tmp_path).as_posix(): n for p in figures if (n := crossing_pixels(p))}
    assert not clipped, f"figures with something across their edge (pixels): {clipped}"
