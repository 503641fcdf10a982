"""Path following in the image of a parameter box: move a mapped point along a straight segment by small
parameter changes inside the box, and say where it can go no further.

A region that is the image of a box of parameters (a robot's tip over its tension box, or a known shape's
parametrisation) has its boundary where the map, restricted to the parameters still free of their bounds, stops
being onto in the direction of travel. Following a segment from a point of the region, the parameters change by
the smallest step (scaled by the box's span) that moves the image along the segment, clipped to the box; where
no such step exists (every parameter that could help is at a bound, or the map's rank is lost, or the map
refuses the point: a robot's equilibrium that does not converge or is not stable), the segment leaves the
region there, to within the follow's resolution.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.optimize import linprog, lsq_linear

__all__ = ["MappedPoint", "ParameterMap", "follow"]

#: weight of the step's size against the image's miss in the bounded least-squares step (on span-scaled steps)
_NORM_WEIGHT = 1e-6
#: Newton corrections of one step before the step is halved
_CORRECTIONS = 4
#: the fraction of the linearised room to the box's faces a step aims at: short of the boundary, which the
#: linearisation misplaces by the square of the room, so that the room shrinks tenfold per step
_SHORT = 0.9
#: a boundary made by the box's faces is taken where the linearisation puts it once it is closer than this many
#: resolutions: the linearisation misplaces it by the square of the room, far below the resolution
_ACCEPT = 10.0


@dataclass(frozen=True, eq=False)
class MappedPoint:
    """One parameter vector and its image.

    Attributes
    ----------
    u : ndarray, shape (m,)
        The parameters (a robot's tensions [N]).
    x : ndarray, shape (3,)
        Their image (a robot's tip [m]).
    jac : ndarray, shape (3, m)
        dx/du at ``u``.
    state : object
        What the map needs to continue from this point (a robot's solved equilibrium); ``None`` for a plain map.
    """

    u: np.ndarray
    x: np.ndarray
    jac: np.ndarray
    state: object = None


class ParameterMap(Protocol):
    """A map from a box of parameters to points in space, evaluated by continuation from a nearby point.

    ``lower`` and ``upper`` (shape (m,)) bound the box. ``evaluate(u, start)`` returns the image of ``u`` reached
    from ``start`` (``None`` for a seed), or ``None`` where the map has no admissible image there (for a robot:
    the equilibrium did not converge, or is not stable). A map may also set ``reached`` after a refusal: the
    share of the straight path from ``start.u`` to ``u`` where its branch ends at a fold (``None``: not known).
    """

    lower: np.ndarray
    upper: np.ndarray

    def evaluate(self, u: np.ndarray, start: MappedPoint | None) -> MappedPoint | None:  # pragma: no cover
        ...


def _bounded_step(point: MappedPoint, miss: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The parameter step du inside the box that best moves the image by ``miss``.

    Minimises ``|J du - miss|^2 + w^2 |du / span|^2 * s^2`` over ``lower <= u + du <= upper``, with ``s`` the
    scale of ``J`` on span-scaled steps and ``w`` = :data:`_NORM_WEIGHT`: the least-norm step where the image can
    move by ``miss``, the best it can where it cannot.
    """
    span = np.maximum(upper - lower, 1e-300)
    scaled = point.jac * span  # dx per unit of span-scaled step
    scale = max(float(np.linalg.norm(scaled, 2)), 1e-300)
    a = np.vstack([scaled, _NORM_WEIGHT * scale * np.eye(span.size)])
    b = np.concatenate([miss, np.zeros(span.size)])
    lo = (lower - point.u) / span
    hi = (upper - point.u) / span
    fixed = hi - lo <= 0.0
    hi = np.where(fixed, lo + 1e-300, hi)  # lsq_linear needs lo < hi; a fixed parameter stays put
    step = lsq_linear(a, b, bounds=(lo, hi), method="bvls").x
    step[fixed] = 0.0
    return step * span


def _reach(fmap: ParameterMap, point: MappedPoint, goal: np.ndarray, tol: float,
           line: tuple[np.ndarray, np.ndarray, float] | None = None) -> MappedPoint | float | None:
    """Newton in image space from ``point`` to ``goal`` by bounded steps: the point within ``tol`` of ``goal``,
    or ``None`` when the corrections do not get there.

    With ``line`` = (origin, unit direction, slack), a point within ``tol`` of the line and within ``slack`` of
    ``goal`` along it is accepted too: a follow needs its points on the segment, not at given places on it.
    Where the first step fails at a fold whose place the map reports (``fmap.reached``), that share of the step
    is returned instead of ``None``.
    """
    current = point
    for k in range(_CORRECTIONS):
        du = _bounded_step(current, goal - current.x, fmap.lower, fmap.upper)
        u = np.clip(current.u + du, fmap.lower, fmap.upper)
        nxt = fmap.evaluate(u, current)
        if nxt is None:
            reached = getattr(fmap, "reached", None)
            return float(reached) if k == 0 and reached is not None else None
        miss = nxt.x - goal
        if np.linalg.norm(miss) <= tol:
            return nxt
        if line is not None:
            along = float(miss @ line[1])
            if abs(along) <= line[2] and np.linalg.norm(miss - along * line[1]) <= tol:
                return nxt
        if np.linalg.norm(miss) >= np.linalg.norm(current.x - goal):
            return None
        current = nxt
    return None


def _linear_reach(point: MappedPoint, miss: np.ndarray, fmap: ParameterMap, tol: float) -> bool:
    """Whether the linearised map moves the image by ``miss`` with a step inside the box (to within ``tol``)."""
    du = _bounded_step(point, miss, fmap.lower, fmap.upper)
    return bool(np.linalg.norm(point.jac @ du - miss) <= tol)


def _limit(point: MappedPoint, direction: np.ndarray, lower: np.ndarray, upper: np.ndarray, most: float) -> float:
    """How far the image can move along the unit ``direction`` before a parameter meets its bound, to first order.

    Solves the linear programme ``max s`` over ``(du, s)`` with ``J du = s direction``,
    ``lower <= u + du <= upper`` and ``0 <= s <= most``; ``most`` where the programme is unbounded or fails.
    """
    m = point.u.size
    span = np.maximum(upper - lower, 1e-300)
    a_eq = np.hstack([point.jac * span, -direction[:, None]])
    lows, highs = (lower - point.u) / span, (upper - point.u) / span
    bounds = [*zip(lows, highs, strict=True), (0.0, most)]
    cost = np.zeros(m + 1)
    cost[-1] = -1.0
    res = linprog(cost, A_eq=a_eq, b_eq=np.zeros(3), bounds=bounds, method="highs")
    return float(res.x[-1]) if res.status == 0 else most


def follow(fmap: ParameterMap, start: MappedPoint, target: np.ndarray, tol: float,
           resolution: float) -> tuple[MappedPoint, float]:
    """Follow the straight segment from ``start.x`` to ``target`` in the map's image.

    Steps along the segment, each reached by bounded Newton steps (:func:`_reach`) to within ``tol`` of the
    segment (:func:`_reach`). No step aims past where the linearised map meets the parameter box (:func:`_limit`),
    so a boundary made by the box's faces is met in a few steps that converge quadratically; a step that fails
    (a fold of the map, a point the map refuses, or a failure on the step's straight path in parameters, which
    a shorter step may avoid) is halved until shorter than ``resolution``, and doubled after each success.

    Parameters
    ----------
    fmap : ParameterMap
        The map.
    start : MappedPoint
        Where the segment starts (a point of the region).
    target : ndarray, shape (3,)
        Where it ends.
    tol : float
        How close to the segment each point must lie (units of the image).
    resolution : float
        The boundary's place along the segment is found to within this (units of the image).

    Returns
    -------
    point : MappedPoint
        The last point reached on the segment (``start`` if none).
    t : float
        1 exactly when the target was reached; otherwise where the segment leaves the region (0 at
        ``start.x``).
    """
    origin = start.x
    length = float(np.linalg.norm(target - origin))
    if length <= tol:
        return start, 1.0
    direction = (target - origin) / length
    current, s, ds = start, 0.0, length
    while True:
        step = min(ds, length - s)
        if not _linear_reach(current, origin + (s + step) * direction - current.x, fmap, tol):
            room = _limit(current, direction, fmap.lower, fmap.upper, length - s)
            if room < _ACCEPT * resolution and s + room < length:
                return current, (s + room) / length
            step = min(step, _SHORT * room)
        last = s + step >= length
        goal = target if last else origin + (s + step) * direction
        nxt = _reach(fmap, current, goal, tol, None if last else (origin, direction, 0.25 * step))
        if isinstance(nxt, float):  # the branch folds this share of the way: aim short of it
            if nxt * step < _ACCEPT * resolution:
                return current, (s + nxt * step) / length
            ds = _SHORT * nxt * step
            continue
        if nxt is None:  # a refused point before s + step, or a failure on the step's path in parameters
            ds = 0.5 * step
            if ds < resolution:  # the boundary lies between s and s + step: say the middle
                return current, (s + ds) / length
            continue
        if last:
            return nxt, 1.0
        current, s = nxt, max(float((nxt.x - origin) @ direction), s)
        ds = 2.0 * step
