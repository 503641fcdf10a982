"""One colour per meaning, shared by every matplotlib figure and the live explorer.

Colours are hex strings (``"#rrggbb"``) that matplotlib and plotly both read. The qualitative colours are
Okabe and Ito's colour-blind-safe set; a meaning keeps its colour in every figure, so a reader who has learnt
that the tip force is orange in one figure reads it so in the next. This module imports nothing and draws
nothing.

Examples
--------
>>> from pytdcr.palette import PALETTE
>>> PALETTE.tip_force
'#e69f00'
>>> PALETTE.model("sscr")
'#0072b2'
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["PALETTE", "Palette"]


def _series() -> tuple[str, ...]:
    return ("#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9", "#f0e442", "#000000")


@dataclass(frozen=True)
class Palette:
    """The colour of each meaning drawn by pytdcr's figures and explorer.

    Attributes
    ----------
    backbone, disks, tendons : str
        The robot: its backbone curve, its disks, its tendons' paths.
    frame_x, frame_y, frame_z : str
        The axes of a drawn frame (red, green, blue by the usual convention).
    tip_force, tip_moment : str
        The tip wrench's arrows: the force and the moment's axis.
    target : str
        A target point of inverse statics and the line from the tip to it.
    region, region_edge : str
        A workspace region (the continued or loading-path region, stable equilibria): its fill and its outline.
    realisable : str
        The realisable part of a region under a load (stable and within the tendons' limits).
    reference : str
        A reference or second region drawn beside the first (e.g. without a load).
    samples : str
        Individual sampled tips drawn behind a region or a fit.
    fit : str
        A fitted curve or an optimum drawn over samples.
    warning : str
        Unstable equilibria, another branch than the one asked for, a run that did not converge.
    failed : str
        Solves that did not converge (their marks, never their shapes).
    series : tuple of str
        Qualitative colours for numbered series (load cases, designs), in order.
    models : tuple of tuple of (str, str)
        A model's registry name and its colour; :meth:`model` reads it.
    """

    backbone: str = "#1a1a1a"
    disks: str = "#7f7f7f"
    tendons: str = "#b03a2e"
    frame_x: str = "#d62728"
    frame_y: str = "#2ca02c"
    frame_z: str = "#1f77b4"
    tip_force: str = "#e69f00"
    tip_moment: str = "#8e44ad"
    target: str = "#cc79a7"
    region: str = "#56b4e9"
    region_edge: str = "#0072b2"
    realisable: str = "#e69f00"
    reference: str = "#009e73"
    samples: str = "#b3b3b3"
    fit: str = "#d55e00"
    warning: str = "#d55e00"
    failed: str = "#000000"
    series: tuple[str, ...] = field(default_factory=_series)
    models: tuple[tuple[str, str], ...] = (("pcc", "#d55e00"), ("pcc2", "#e69f00"), ("sscr", "#0072b2"),
                                           ("cosserat", "#009e73"))

    def model(self, name: str) -> str:
        """The colour of the model registered as ``name``; a model without one gets the last series colour."""
        return dict(self.models).get(name, self.series[-1])

    def nth(self, k: int) -> str:
        """The ``k``-th series colour (cycling), for load cases, designs and other numbered series."""
        return self.series[k % len(self.series)]


PALETTE = Palette()
