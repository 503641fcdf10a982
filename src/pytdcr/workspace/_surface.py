"""A region from its boundary: grid nodes labelled by following the map between them, the cells that straddle
the boundary refined level by level, and a surface through the exact boundary crossings, whose volume is
second order in the grid's spacing.

The region is the image of a parameter box (:class:`~._follow.ParameterMap`) reached from seed points. On a
coarse grid every node is labelled by following grid edges from nodes already reached (:func:`~._follow.follow`):
a node the follow reaches is inside, with the parameters that reach it; a follow that stops records where its
edge crosses the boundary. Each finer level halves the spacing and recomputes only the nodes of cells whose
corners disagree (and of any cell whose fill a computed node contradicts); the other cells are filled with their
corners' label. The work therefore grows with the boundary's area, not the region's volume. The surface is
marching cubes of the labels with each vertex moved from its edge's midpoint to the recorded crossing, so its
volume converges at second order; the change of volume between the last two levels is the error.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from itertools import product

import numpy as np
from scipy.spatial import cKDTree

from ._follow import MappedPoint, ParameterMap, follow

__all__ = ["SurfaceSettings", "TracedSurface", "mesh_volume", "reached_by_follow", "trace_surface", "winding_numbers"]

_UNKNOWN, _OUT, _IN = -1, 0, 1
_STEPS = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)])


@dataclass(frozen=True)
class SurfaceSettings:
    """How finely a region's boundary is traced.

    Attributes
    ----------
    spacing : float
        The coarse grid's spacing (units of the image; a robot's: m). Features thinner than it can be missed.
    levels : int
        Refinements after the coarse grid: the finest spacing is ``spacing / 2**levels``.
    tol : float
        How close to a grid edge a followed point must lie, as a fraction of the level's spacing.
    resolution : float
        Where a follow stops at a fold or a refused point is the boundary to within this fraction of the level's
        spacing; a boundary made by the box's faces is placed far closer (:func:`~._follow.follow`).
    """

    spacing: float
    levels: int = 2
    tol: float = 1e-3
    resolution: float = 1e-2


@dataclass(frozen=True, eq=False)
class TracedSurface:
    """A traced region: its surface at the finest level, and the volume at every level.

    Attributes
    ----------
    vertices : ndarray, shape (nv, 3)
        The surface's vertices (the boundary crossings), in the image's frame.
    faces : ndarray of int, shape (nf, 3)
        Its triangles, outward by the right-hand rule.
    spacings : tuple of float
        Each level's grid spacing, coarse to fine.
    volumes : tuple of float
        The volume enclosed at each level.
    evaluations : tuple of int
        The map's evaluations spent on each level.
    unresolved : int
        Surface vertices at the finest level with no recorded crossing (placed at their edge's midpoint).
    points : tuple of MappedPoint
        The finest level's reached nodes: each with the parameters that reach it, its image and the map's state.
    """

    vertices: np.ndarray
    faces: np.ndarray
    spacings: tuple[float, ...]
    volumes: tuple[float, ...]
    evaluations: tuple[int, ...]
    unresolved: int
    points: tuple[MappedPoint, ...] = ()

    @property
    def volume(self) -> float:
        """The volume at the finest level."""
        return self.volumes[-1]

    @property
    def volume_err(self) -> float:
        """The change of volume from the level before: for a second-order method about three times the finest
        level's own error (0 with one level)."""
        return abs(self.volumes[-1] - self.volumes[-2]) if len(self.volumes) > 1 else float("inf")


class _Counted:
    """A map that counts its evaluations."""

    def __init__(self, fmap: ParameterMap) -> None:
        self.fmap, self.lower, self.upper, self.count = fmap, fmap.lower, fmap.upper, 0

    def evaluate(self, u: np.ndarray, start: MappedPoint | None) -> MappedPoint | None:
        self.count += 1
        return self.fmap.evaluate(u, start)

    @property
    def reached(self) -> float | None:
        """The map's ``reached`` after its last refusal (:class:`~._follow.ParameterMap`)."""
        return getattr(self.fmap, "reached", None)


@dataclass(eq=False)
class _Level:
    """One level's grid: labels (computed or predicted), which are computed, the reached points (node to
    :class:`MappedPoint`), the crossings ((inside node, outside node) to the crossing's place on their edge from
    the inside node) and the cells processed."""

    origin: np.ndarray
    spacing: float
    labels: np.ndarray
    known: np.ndarray
    points: dict[int, MappedPoint] = field(default_factory=dict)
    crossings: dict[tuple[int, int], float] = field(default_factory=dict)
    processed: set[tuple[int, int, int]] = field(default_factory=set)

    def position(self, flat: int) -> np.ndarray:
        return self.origin + self.spacing * np.array(np.unravel_index(flat, self.labels.shape), dtype=float)

    def neighbours(self, flat: int) -> list[int]:
        idx = np.array(np.unravel_index(flat, self.labels.shape))
        shape = np.array(self.labels.shape)
        out = []
        for step in _STEPS:
            nb = idx + step
            if np.all(nb >= 0) and np.all(nb < shape):
                out.append(int(np.ravel_multi_index(tuple(nb), self.labels.shape)))
        return out


def _flood(level: _Level, fmap: _Counted, queue: deque[int], settings: SurfaceSettings) -> None:
    """Label nodes by following edges out of reached nodes; record each stopped follow's crossing."""
    labels = level.labels.reshape(-1)
    while queue:
        a = queue.popleft()
        for b in level.neighbours(a):
            if labels[b] == _IN or (a, b) in level.crossings:
                continue
            if _follow_to(level, fmap, a, b, settings) >= 1.0:
                queue.append(b)


def _settle(level: _Level, fmap: _Counted, settings: SurfaceSettings) -> None:
    """Label the nodes no edge reached: those beside an inside node are followed to from the nearest reached
    point (straight, not along edges); the rest are outside."""
    labels = level.labels.reshape(-1)
    while True:
        unknown = np.flatnonzero(labels == _UNKNOWN)
        pending = [b for b in unknown if any(labels[n] == _IN for n in level.neighbours(int(b)))]
        if not pending or not level.points:
            labels[unknown] = _OUT
            level.known.flat[unknown] = True
            return
        keys = np.array(list(level.points))
        tree = cKDTree(np.array([level.position(int(k)) for k in keys]))
        queue: deque[int] = deque()
        for b in pending:
            _, i = tree.query(level.position(int(b)))
            if _follow_to(level, fmap, int(keys[i]), int(b), settings) >= 1.0:
                queue.append(int(b))
        _flood(level, fmap, queue, settings)


def _coarse(fmap: _Counted, seeds: list[MappedPoint], lo: np.ndarray, hi: np.ndarray,
            settings: SurfaceSettings) -> _Level:
    """The coarse grid over the box [lo, hi], every node computed, flooded from the seeds."""
    shape = tuple(int(np.ceil((h - lo_) / settings.spacing)) + 1 for lo_, h in zip(lo, hi, strict=True))
    level = _Level(origin=np.asarray(lo, dtype=float), spacing=settings.spacing,
                   labels=np.full(shape, _UNKNOWN, dtype=np.int8), known=np.zeros(shape, dtype=bool))
    labels = level.labels.reshape(-1)
    queue: deque[int] = deque()
    tol, res = settings.tol * level.spacing, settings.resolution * level.spacing
    for seed in seeds:
        idx = np.clip(np.rint((seed.x - level.origin) / level.spacing).astype(int), 0, np.array(shape) - 1)
        b = int(np.ravel_multi_index(tuple(idx), shape))
        if labels[b] == _IN:
            continue
        point, t = follow(fmap, seed, level.position(b), tol, res)
        if t >= 1.0:
            _record(level, -1, b, point, t)
            queue.append(b)
    _flood(level, fmap, queue, settings)
    _settle(level, fmap, settings)
    return level


_CORNERS = np.array(list(product((0, 1), repeat=3)))
_EDGES = [(i, j) for i in range(8) for j in range(i + 1, 8) if np.abs(_CORNERS[i] - _CORNERS[j]).sum() == 1]


def _predict(coarse: _Level) -> tuple[np.ndarray, np.ndarray]:
    """The finer level's labels as the coarse level predicts them, and which are known.

    Coarse nodes keep their labels (known where computed); an edge's midpoint takes its edge's label, or, on an
    edge that crosses the boundary, the side of the crossing it lies on; a face's or a cell's centre takes its
    corners' label where they agree, and is unknown where they do not.
    """
    n = np.array(coarse.labels.shape)
    shape = tuple(int(v) for v in 2 * (n - 1) + 1)
    labels = np.full(shape, _UNKNOWN, dtype=np.int8)
    for par in product((0, 1), repeat=3):
        corners = [coarse.labels[tuple(slice(c, m - p + c) for c, p, m in zip(choice, par, n, strict=True))]
                   for choice in product(*[(0, 1) if p else (0,) for p in par])]
        lo, hi = np.minimum.reduce(corners), np.maximum.reduce(corners)
        labels[tuple(slice(p, None, 2) for p in par)] = np.where(lo == hi, lo, _UNKNOWN)
    for (a, b), t in coarse.crossings.items():
        ia = np.array(np.unravel_index(a, tuple(n)))
        ib = np.array(np.unravel_index(b, tuple(n)))
        if coarse.labels.flat[a] == _IN and coarse.labels.flat[b] == _OUT and np.abs(ia - ib).sum() == 1:
            labels[tuple(ia + ib)] = _IN if t > 0.5 else _OUT
    known = np.zeros(shape, dtype=bool)
    known[::2, ::2, ::2] = coarse.known
    return labels, known


def _fine_index(coarse: _Level, fine_shape: tuple[int, ...]) -> dict[int, int]:
    """Each coarse node's index on the finer grid."""
    n = coarse.labels.shape
    strides = np.array([fine_shape[1] * fine_shape[2], fine_shape[2], 1])
    return {int(f): int(2 * np.array(np.unravel_index(f, n)) @ strides) for f in coarse.points}


def _cell_nodes(level: _Level, cell: tuple[int, int, int]) -> list[int]:
    """The flat indices of a cell's 8 corners, in the order of :data:`_CORNERS`."""
    shape = level.labels.shape
    return [int(np.ravel_multi_index(tuple(np.array(cell) + c), shape)) for c in _CORNERS]


def _compute(level: _Level, fmap: _Counted, node: int, settings: SurfaceSettings) -> bool:
    """Label a node by following to it from a reached neighbour; ``False`` when no neighbour is reached."""
    for a in level.neighbours(node):
        if a in level.points:
            _follow_to(level, fmap, a, node, settings)
            return True
    return False


def _follow_to(level: _Level, fmap: _Counted, a: int, b: int, settings: SurfaceSettings) -> float:
    """Follow from reached node ``a`` to node ``b`` at the level's tolerances and record the outcome
    (:func:`_record`); the follow's ``t`` (1: ``b`` reached)."""
    point, t = follow(fmap, level.points[a], level.position(b), settings.tol * level.spacing,
                      settings.resolution * level.spacing)
    _record(level, a, b, point, t)
    return t


def _record(level: _Level, a: int, b: int, point: MappedPoint, t: float) -> None:
    """Record a follow from reached node ``a`` to node ``b``: ``b`` reached, or the crossing between them."""
    flat = level.labels.reshape(-1)
    level.known.flat[b] = True
    if t >= 1.0:
        flat[b] = _IN
        level.points[b] = point
    else:
        level.crossings[(a, b)] = t
        if b not in level.points:
            flat[b] = _OUT


def _process(level: _Level, fmap: _Counted, cell: tuple[int, int, int], settings: SurfaceSettings) -> list[int]:
    """Compute a cell's corners and the crossings of its edges; the nodes that turned from outside to inside."""
    nodes = _cell_nodes(level, cell)
    flat = level.labels.reshape(-1)
    pending = [n for n in nodes if not level.known.flat[n]]
    while pending:
        done = [n for n in pending if _compute(level, fmap, n, settings)]
        if not done:  # no path along grid edges reaches them yet: outside until an edge's follow reaches one
            level.known.flat[pending] = True
            flat[pending] = _OUT
            break
        pending = [n for n in pending if n not in done]
    flipped = []
    for i, j in _EDGES:
        a, b = nodes[i], nodes[j]
        if flat[a] == flat[b]:
            continue
        a, b = (a, b) if flat[a] == _IN else (b, a)
        if (a, b) not in level.crossings and _follow_to(level, fmap, a, b, settings) >= 1.0:
            flipped.append(b)
    return flipped


def _cells_of(level: _Level, node: int) -> list[tuple[int, int, int]]:
    """The cells a node is a corner of."""
    idx = np.unravel_index(node, level.labels.shape)
    ranges = [range(max(i - 1, 0), min(i, n - 2) + 1) for i, n in zip(idx, level.labels.shape, strict=True)]
    return [tuple(int(v) for v in c) for c in product(*ranges)]


def _mixed_faces(level: _Level, cell: tuple[int, int, int]) -> list[tuple[int, int, int]]:
    """The neighbouring cells across this cell's faces whose corners disagree."""
    lab = level.labels[cell[0]:cell[0] + 2, cell[1]:cell[1] + 2, cell[2]:cell[2] + 2]
    out = []
    for axis in range(3):
        for side in (0, 1):
            face = np.take(lab, side, axis=axis)
            if face.min() != face.max():
                nb = list(cell)
                nb[axis] += 1 if side else -1
                if 0 <= nb[axis] < level.labels.shape[axis] - 1:
                    out.append(tuple(nb))
    return out


def _track(level: _Level, fmap: _Counted, queue: deque[tuple[int, int, int]], settings: SurfaceSettings) -> None:
    """Process cells from the queue, moving on across every face the boundary crosses."""
    done = level.processed
    while queue:
        cell = queue.popleft()
        if cell in done:
            continue
        done.add(cell)
        for node in _process(level, fmap, cell, settings):
            for other in _cells_of(level, node):
                done.discard(other)
                queue.append(other)
        queue.extend(c for c in _mixed_faces(level, cell) if c not in done)


def _unsettled(level: _Level) -> list[tuple[int, int, int]]:
    """Cells not processed whose corners disagree or are not all known to agree (unknown corners)."""
    lab = level.labels
    corners = [lab[c0:lab.shape[0] - 1 + c0, c1:lab.shape[1] - 1 + c1, c2:lab.shape[2] - 1 + c2]
               for c0, c1, c2 in _CORNERS]
    lo, hi = np.minimum.reduce(corners), np.maximum.reduce(corners)
    cells = [tuple(int(v) for v in c) for c in np.argwhere((lo != hi) | (lo == _UNKNOWN))]
    return [c for c in cells if c not in level.processed]


def _finer(coarse: _Level, fmap: _Counted, settings: SurfaceSettings) -> _Level:
    """The next level by tracking the boundary: cells around the coarse crossings first, then across every
    face the boundary crosses, until no cell with disagreeing corners is left unprocessed."""
    labels, known = _predict(coarse)
    level = _Level(origin=coarse.origin, spacing=coarse.spacing / 2, labels=labels, known=known)
    index = _fine_index(coarse, labels.shape)
    level.points = {index[f]: p for f, p in coarse.points.items()}
    queue: deque[tuple[int, int, int]] = deque()
    for cell in _unsettled(level):
        queue.append(cell)
    while queue:
        _track(level, fmap, queue, settings)
        queue.extend(_unsettled(level))
    level.labels[level.labels == _UNKNOWN] = _OUT
    return level


def _surface(level: _Level) -> tuple[np.ndarray, np.ndarray, int]:
    """Marching cubes of the labels with each vertex at its edge's recorded crossing.

    A vertex that marching cubes puts inside a cell (to keep an ambiguous cell's surface closed) stays there;
    a vertex on an edge with no recorded crossing stays at the edge's middle and is counted (``unresolved``).
    """
    from skimage.measure import marching_cubes

    inside = level.labels == _IN
    if not inside.any() or inside.all():
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=int), 0
    verts, faces, _, _ = marching_cubes(np.pad(inside.astype(np.float32), 1), level=0.5)
    verts = verts.astype(float) - 1.0
    points = level.origin + level.spacing * verts
    base = np.floor(verts + 1e-9).astype(int)
    half = np.abs(verts - base - 0.5) < 1e-6
    on_edge = np.flatnonzero(half.sum(axis=1) == 1)
    axis = np.argmax(half[on_edge], axis=1)
    other = base[on_edge].copy()
    other[np.arange(on_edge.size), axis] += 1
    shape = level.labels.shape
    a = np.ravel_multi_index(tuple(np.clip(base[on_edge], 0, np.array(shape) - 1).T), shape)
    b = np.ravel_multi_index(tuple(np.clip(other, 0, np.array(shape) - 1).T), shape)
    a_in = level.labels.reshape(-1)[a] == _IN
    inner, outer = np.where(a_in, a, b), np.where(a_in, b, a)
    t = np.array([level.crossings.get((int(i), int(o)), np.nan) for i, o in zip(inner, outer, strict=True)])
    unresolved = int(np.isnan(t).sum())
    t = np.where(np.isnan(t), 0.5, t)
    pi = np.array(np.unravel_index(inner, shape), dtype=float).T
    po = np.array(np.unravel_index(outer, shape), dtype=float).T
    points[on_edge] = level.origin + level.spacing * (pi + t[:, None] * (po - pi))
    return points, faces[:, ::-1].astype(int), unresolved


def mesh_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The volume a closed triangle mesh encloses: the sum of its faces' signed tetrahedra from the origin,
    ``V = sum(v0 . (v1 x v2)) / 6`` (positive for outward faces)."""
    if not len(faces):
        return 0.0
    v0, v1, v2 = (vertices[faces[:, i]] for i in range(3))
    return float(np.einsum("ij,ij->i", v0, np.cross(v1, v2)).sum() / 6.0)


def winding_numbers(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The winding number of a closed, outward triangle mesh round each point: 1 inside, 0 outside.

    The sum of the faces' signed solid angles seen from the point over 4 pi (Van Oosterom and Strackee:
    ``tan(omega / 2) = a . (b x c) / (|a||b||c| + (a.b)|c| + (b.c)|a| + (c.a)|b|)`` with a, b, c the corners
    relative to the point). ``points`` shape (k, 3); returns shape (k,).
    """
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    out = np.zeros(len(pts))
    tri = vertices[faces]  # (n, 3, 3)
    for i, p in enumerate(pts):
        a, b, c = (tri[:, j] - p for j in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la
               + np.einsum("ij,ij->i", c, a) * lb)
        out[i] = 2.0 * np.arctan2(num, den).sum() / (4.0 * np.pi)
    return out


def trace_surface(fmap: ParameterMap, seeds: list[MappedPoint], lo: np.ndarray, hi: np.ndarray,
                  settings: SurfaceSettings) -> TracedSurface:
    """Trace the region of ``fmap``'s image reached from ``seeds`` inside the box [lo, hi].

    Parameters
    ----------
    fmap : ParameterMap
        The map whose image is the region.
    seeds : list of MappedPoint
        Points of the region to start from (followed to their nearest coarse node).
    lo, hi : ndarray, shape (3,)
        A box that holds the region with a margin (nodes on its faces should be outside).
    settings : SurfaceSettings
        The coarse spacing, the levels and the follow's tolerances.

    Returns
    -------
    TracedSurface
        The finest level's surface, and each level's volume and evaluations.
    """
    counted = _Counted(fmap)
    level = _coarse(counted, seeds, np.asarray(lo, dtype=float), np.asarray(hi, dtype=float), settings)
    spacings, volumes, evaluations = [level.spacing], [], [counted.count]
    verts, faces, unresolved = _surface(level)
    volumes.append(mesh_volume(verts, faces))
    for _ in range(settings.levels):
        before = counted.count
        level = _finer(level, counted, settings)
        verts, faces, unresolved = _surface(level)
        spacings.append(level.spacing)
        volumes.append(mesh_volume(verts, faces))
        evaluations.append(counted.count - before)
    return TracedSurface(vertices=verts, faces=faces, spacings=tuple(spacings), volumes=tuple(volumes),
                         evaluations=tuple(evaluations), unresolved=unresolved,
                         points=tuple(level.points[k] for k in sorted(level.points)))


def reached_by_follow(fmap: ParameterMap, surface: TracedSurface, targets: np.ndarray, starts: int,
                      settings: SurfaceSettings) -> np.ndarray:
    """Whether a straight follow reaches each target from one of the ``starts`` reached nodes of ``surface``
    nearest it (tried nearest first), at the finest level's tolerances.

    The region's membership is a property of paths: a target that one straight follow does not reach may be
    reached by another, so the share reached grows with ``starts``. ``targets`` shape (k, 3); returns (k,) bool.
    """
    pts = np.atleast_2d(np.asarray(targets, dtype=float))
    out = np.zeros(len(pts), dtype=bool)
    if not surface.points:
        return out
    h = surface.spacings[-1]
    tree = cKDTree(np.array([p.x for p in surface.points]))
    _, nearest = tree.query(pts, k=min(starts, len(surface.points)))
    for i, row in enumerate(np.reshape(nearest, (len(pts), -1))):
        out[i] = any(follow(fmap, surface.points[j], pts[i], settings.tol * h, settings.resolution * h)[1] >= 1.0
                     for j in row)
    return out
