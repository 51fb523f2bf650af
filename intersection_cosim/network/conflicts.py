"""Conflict points between movement paths (paper Section II, Fig. 1), computed once per net.

The paper names three kinds of driving conflict between two vehicles:

- **following**: same driving direction and trajectory (here: the two paths start on the same
  approach lane and share a stretch of centre line);
- **cross**: different directions whose trajectories intersect;
- **confluence**: two vehicles merge into the same lane from different lanes (here: two paths from
  different approach lanes that end on the same exit lane).

For every pair of paths (both orientations, and each path with itself) :func:`conflict_points`
returns at most one :class:`ConflictPoint`. The rules, applied in this order:

1. Same approach lane -> **following**. The shared stretch starts at s = 0 on both paths (they
   share their first lane), so points at equal arc length are compared; the stretch ends at the
   first arc length where the two centre lines are ``vehicle_width`` or more apart (beyond it two
   vehicles are side by side without overlapping). ``s_a = s_b`` = that end. For a path with
   itself the whole path is shared (``s = length``).
2. Same exit lane, different approach lanes -> **confluence**. The conflict point on each path is
   the first arc length (inside the junction, at the latest where the path enters the exit lane)
   at which the *other* centre line is closer than ``vehicle_width``: from there on the two
   vehicle bodies (each ``vehicle_width`` wide) can overlap, so that is where a collision can first
   happen. For a merge this lies a few metres before the exit lane; if the centre lines cross
   earlier it is at (just before) the crossing. ``(x, y)`` is the midpoint of the two points.
3. Otherwise, centre lines that cross inside the junction -> **cross** at the crossing with the
   smallest arc length on the first path of the pair (paths sorted by id, so both orientations
   describe the same point), found with :func:`sumolib.geomhelper.intersectsAtLengths2D`. Centre
   lines that do not cross but come closer than ``vehicle_width`` inside the junction -> **cross**
   at the closest approach (``(x, y)`` the midpoint).
4. Otherwise no conflict: the pair is absent.

A point is where the centre lines meet; two bodies 4.5 m x 1.8 m meet over a stretch. For a
**cross** pair the table also holds that stretch on each path (:func:`conflict_zone`): the front
arc lengths ``[zone_in, zone_out]`` over which the body of a vehicle on ``a`` overlaps the area
that ``b``'s bodies sweep through the junction. A vehicle whose front is past
``zone_out`` has cleared the crossing whatever the other does; an oblique crossing (a left turn)
takes several metres more than ``s_a + length`` to clear, which a point plus a constant misses.

Only paths through the same junction are paired. For the movements of any net
(:func:`movement_conflicts`), SUMO's foe relation between the junction's links is a second
opinion: a foe pair the rules above find no conflict for is guarded as a **cross** conflict at the
closest approach of the two junction stretches.

Outside the junction, paths on different lanes run 4 m apart, so only the junction stretch
``[s_stop, s_exit]`` (plus one resampling step either side) is searched for rules 2 and 3.

:class:`ConflictTable` packs the result into ``(P, P)`` numpy arrays indexed by integer path
indices, which is what the run-time code (risk, ETM, controllers) uses: looking up the conflict points of
all vehicle pairs is one fancy-indexing operation.

Pure data; reads the net only through :func:`~intersection_cosim.network.paths.load_paths` (or a
:class:`~intersection_cosim.network.movements.Movements` built beforehand).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path as FsPath

import numpy as np
from scipy.spatial import cKDTree
from sumolib import geomhelper

from intersection_cosim.network.conflict_cache import disk_cached, inputs_digest
from intersection_cosim.network.conflict_zones import ZONE_MERGE, coarse_zone, conflict_zone, point_zone, swept_area
from intersection_cosim.network.movements import Movements
from intersection_cosim.network.paths import MovementPath, load_paths

KIND_NONE = 0
KIND_FOLLOWING = 1
KIND_CROSS = 2
KIND_CONFLUENCE = 3
KIND_NAMES = ("none", "following", "cross", "confluence")  # index = kind code
KIND_CODE = {name: code for code, name in enumerate(KIND_NAMES)}

_CROSS_CANDIDATE = 0.75  # [m] sample pairs closer than this may hold a crossing of their segments


@dataclass(frozen=True)
class ConflictPoint:
    """The conflict point of path ``path_a`` with path ``path_b`` (paper Section II, Fig. 1).

    ``s_a`` / ``s_b`` [m] are its arc lengths along ``path_a`` / ``path_b`` (for ``following``: the
    end of the shared stretch); ``x``, ``y`` [m] its position in the paper frame.
    """

    path_a: str
    path_b: str
    kind: str  # "cross" | "confluence" | "following"
    s_a: float  # [m] arc length of the point on path_a
    s_b: float  # [m] arc length of the point on path_b
    x: float  # [m]
    y: float  # [m]

    def swapped(self) -> ConflictPoint:
        """The same point seen from ``path_b``."""
        return ConflictPoint(self.path_b, self.path_a, self.kind, self.s_b, self.s_a, self.x, self.y)


def _junction_part(path: MovementPath) -> tuple[np.ndarray, np.ndarray]:
    """Arc lengths [m] and points [m] of the junction stretch, one resampling step either side."""
    step = path.s[1] - path.s[0]
    keep = (path.s >= path.s_stop - step) & (path.s <= path.s_exit + step)
    return path.s[keep], path.xy[keep]


def _first_below(s: np.ndarray, d: np.ndarray, limit: float) -> float | None:
    """First arc length [m] where the sampled distance ``d`` [m] drops below ``limit`` (linear
    interpolation between samples), or None."""
    below = np.flatnonzero(d < limit)
    if below.size == 0:
        return None
    k = int(below[0])
    if k == 0:
        return float(s[0])
    d0, d1 = d[k - 1], d[k]
    frac = (d0 - limit) / (d0 - d1) if d0 != d1 else 0.0
    return float(s[k - 1] + frac * (s[k] - s[k - 1]))


def _following(a: MovementPath, b: MovementPath, width: float) -> ConflictPoint:
    if a.id == b.id:
        x, y = a.point_at(a.length)
        return ConflictPoint(a.id, b.id, "following", a.length, b.length, float(x), float(y))
    n = min(len(a.s), len(b.s))
    s = a.s[:n]
    gap = np.linalg.norm(a.point_at(s) - b.point_at(s), axis=1)
    apart = np.flatnonzero(gap >= width)
    end = float(s[apart[0]]) if apart.size else float(min(a.length, b.length))
    x, y = 0.5 * (a.point_at(end) + b.point_at(end))
    return ConflictPoint(a.id, b.id, "following", end, end, float(x), float(y))


def _confluence(a: MovementPath, b: MovementPath, width: float) -> ConflictPoint:
    sa, xa = _junction_part(a)
    sb, xb = _junction_part(b)
    dist = np.linalg.norm(xa[:, None, :] - xb[None, :, :], axis=2)
    s_a = _first_below(sa, dist.min(axis=1), width)
    s_b = _first_below(sb, dist.min(axis=0), width)
    s_a = a.s_exit if s_a is None else min(s_a, a.s_exit)
    s_b = b.s_exit if s_b is None else min(s_b, b.s_exit)
    x, y = 0.5 * (a.point_at(s_a) + b.point_at(s_b))
    return ConflictPoint(a.id, b.id, "confluence", s_a, s_b, float(x), float(y))


def _cross(a: MovementPath, b: MovementPath, width: float) -> ConflictPoint | None:
    sa, xa = _junction_part(a)
    sb, xb = _junction_part(b)
    dist = np.linalg.norm(xa[:, None, :] - xb[None, :, :], axis=2)
    if dist.min() >= width:
        return None
    # Crossings: only segments whose end points are close can intersect; hand sumolib the
    # bounding window of those so it does not scan every segment pair.
    ia, ib = np.nonzero(dist < _CROSS_CANDIDATE)
    if ia.size:
        a0, a1 = int(ia.min()), min(int(ia.max()) + 2, len(sa))
        b0, b1 = int(ib.min()), min(int(ib.max()) + 2, len(sb))
        poly_a = [tuple(p) for p in xa[a0:a1]]
        poly_b = [tuple(p) for p in xb[b0:b1]]
        lengths_a = geomhelper.intersectsAtLengths2D(poly_a, poly_b)
        if lengths_a:
            s_a = float(sa[a0] + min(lengths_a))
            point = a.point_at(s_a)
            lengths_b = geomhelper.intersectsAtLengths2D(poly_b, poly_a)
            cand = sb[b0] + np.asarray(lengths_b, float)
            s_b = float(cand[np.argmin(np.linalg.norm(b.point_at(cand) - point, axis=1))])
            return ConflictPoint(a.id, b.id, "cross", s_a, s_b, float(point[0]), float(point[1]))
    # No crossing, but closer than a vehicle width: the closest approach.
    return _closest(a, b, (sa, xa), (sb, xb), dist)


def _closest(a: MovementPath, b: MovementPath, part_a=None, part_b=None, dist=None) -> ConflictPoint:
    """A **cross** point at the closest approach of the two junction stretches (``(x, y)`` the
    midpoint); the stretches and their distance matrix [m] are computed unless given."""
    sa, xa = part_a if part_a is not None else _junction_part(a)
    sb, xb = part_b if part_b is not None else _junction_part(b)
    if dist is None:
        dist = np.linalg.norm(xa[:, None, :] - xb[None, :, :], axis=2)
    k = np.unravel_index(int(np.argmin(dist)), dist.shape)
    s_a, s_b = float(sa[k[0]]), float(sb[k[1]])
    x, y = 0.5 * (xa[k[0]] + xb[k[1]])
    return ConflictPoint(a.id, b.id, "cross", s_a, s_b, float(x), float(y))


def conflict_point(a: MovementPath, b: MovementPath, vehicle_width: float = 1.8) -> ConflictPoint | None:
    """The conflict point of ``a`` with ``b`` by the rules in the module docstring, or None.

    ``vehicle_width`` [m] is the distance under which two centre lines count as touching.
    """
    if a.approach_lane == b.approach_lane:
        return _following(a, b, vehicle_width)
    if a.lanes[-1] == b.lanes[-1]:
        return _confluence(a, b, vehicle_width)
    return _cross(a, b, vehicle_width)


def conflict_points(paths: dict[str, MovementPath], vehicle_width: float = 1.8,
                    foes: frozenset[tuple[str, str]] = frozenset()) -> dict[tuple[str, str], ConflictPoint]:
    """Conflict points of every pair of paths, keyed ``(a, b)`` with ``s_a`` on ``a``.

    Both orientations are present (``(b, a)`` is the swap of ``(a, b)``), and every path is paired
    with itself as a following conflict. Pairs without a conflict are absent. Only paths through
    the same junction (``MovementPath.junction``) are paired. A pair in ``foes`` (SUMO's right of
    way calls their links foes) for which the rules find no conflict is guarded as a **cross**
    conflict at the closest approach of the two junction stretches.
    """
    ids = sorted(paths)
    out: dict[tuple[str, str], ConflictPoint] = {}
    for n, a in enumerate(ids):
        for b in ids[n:]:
            if paths[a].junction != paths[b].junction:
                continue
            cp = conflict_point(paths[a], paths[b], vehicle_width)
            if cp is None and (a, b) in foes:
                cp = _closest(paths[a], paths[b])
            if cp is None:
                continue
            out[(a, b)] = cp
            out[(b, a)] = cp.swapped()
    return out


@functools.lru_cache(maxsize=8)
def _load_conflicts(net_file: str, vehicle_width: float) -> dict[tuple[str, str], ConflictPoint]:
    return conflict_points(load_paths(net_file), vehicle_width)


def load_conflicts(net_file: str | FsPath, vehicle_width: float = 1.8) -> dict[tuple[str, str], ConflictPoint]:
    """:func:`conflict_points` of the net's paths, cached per (net file, width)."""
    return _load_conflicts(str(net_file), float(vehicle_width))


@dataclass(frozen=True)
class ConflictTable:
    """Paths and their conflict points as arrays indexed by integer path index (hot-path lookup).

    For paths with indices ``p``, ``q``: ``kind[p, q]`` is the kind code (``KIND_NAMES``),
    ``s_a[p, q]`` [m] the conflict point's arc length on path ``p``, ``s_b[p, q]`` [m] on path
    ``q`` (``s_b[p, q] == s_a[q, p]``), ``x``/``y`` [m] its position; NaN where there is none.
    For cross pairs ``zone_in[p, q]`` / ``zone_out[p, q]`` [m] are the front arc lengths on ``p``
    between which a body on ``p`` overlaps the area ``q``'s bodies sweep (:func:`conflict_zone`); NaN otherwise.
    """

    ids: tuple[str, ...]
    index: dict[str, int] = field(repr=False)
    kind: np.ndarray = field(repr=False)  # (P, P) int8
    s_a: np.ndarray = field(repr=False)  # (P, P) [m]
    s_b: np.ndarray = field(repr=False)  # (P, P) [m]
    x: np.ndarray = field(repr=False)  # (P, P) [m]
    y: np.ndarray = field(repr=False)  # (P, P) [m]
    s_stop: np.ndarray = field(repr=False)  # (P,) [m] arc length of each path's stop line
    s_exit: np.ndarray = field(repr=False)  # (P,) [m] arc length where each path enters its exit lane
    length: np.ndarray = field(repr=False)  # (P,) [m] total arc length of each path
    s_wait: np.ndarray = field(repr=False, default=None)  # (P,) [m] each path's MovementPath.s_wait (inf: none)
    zone_in: np.ndarray = field(repr=False, default=None)  # (P, P) [m] cross pairs: see above
    zone_out: np.ndarray = field(repr=False, default=None)  # (P, P) [m]
    body: tuple[float, float] = (4.5, 1.8)  # [m] (length, width) of the bodies zone_in / zone_out are for
    paths: dict | None = field(repr=False, compare=False, default=None)  # path id -> MovementPath (other bodies' zones)
    _other: dict = field(repr=False, compare=False, default_factory=dict)  # cache of :meth:`zone` for other bodies

    def zone(self, p: int, q: int, body_p: tuple[float, float], body_q: tuple[float, float]) -> tuple[float, float]:
        """[m] (zone_in, zone_out) of cross pair (p, q) for a body ``body_p`` (length, width [m])
        on path p against the area bodies ``body_q`` sweep on path q: the table's own arrays for
        its own body, else :func:`conflict_zone` of those bodies, built once per (pair, bodies)
        and cached (one table per pair of size classes, filled as pairs of them meet)."""
        if body_p == self.body and body_q == self.body:
            return float(self.zone_in[p, q]), float(self.zone_out[p, q])
        key = (p, q, body_p, body_q)
        if key not in self._other:
            swept_key = (q, body_q)
            if swept_key not in self._other:
                self._other[swept_key] = swept_area(self.paths[self.ids[q]], *body_q, merge=ZONE_MERGE)
            zone = coarse_zone(self.paths[self.ids[p]], *body_p, self._other[swept_key])
            self._other[key] = zone if zone is not None else point_zone(float(self.s_a[p, q]), *body_p)
        return self._other[key]

    def warm(self, bodies, zones: bool = False) -> None:
        """Build now, so that no control step pays for it, the areas that ``bodies`` ((length,
        width) [m] each) sweep on every path of a cross pair (the costly part of :meth:`zone`,
        ~20 ms each for a bus); with ``zones`` also every cross pair's zone for every ordered pair
        of them (a few ms each; left to the first step that needs it otherwise)."""
        bodies = sorted(set(bodies) | {self.body})
        cross = np.argwhere(self.kind == KIND_CROSS)
        for q in np.unique(cross[:, 1]):
            for body in bodies:
                if body != self.body and (int(q), body) not in self._other:
                    self._other[(int(q), body)] = swept_area(self.paths[self.ids[q]], *body, merge=ZONE_MERGE)
        for p, q in cross if zones else ():
            for body_p in bodies:
                for body_q in bodies:
                    self.zone(int(p), int(q), body_p, body_q)

    @classmethod
    def build(cls, paths: dict[str, MovementPath],
              conflicts: dict[tuple[str, str], ConflictPoint],
              vehicle_length: float = 4.5, vehicle_width: float = 1.8) -> ConflictTable:
        ids = tuple(paths)
        index = {pid: i for i, pid in enumerate(ids)}
        n = len(ids)
        kind = np.zeros((n, n), np.int8)
        s_a, s_b, x, y, zone_in, zone_out = (np.full((n, n), np.nan) for _ in range(6))
        swept: dict[str, cKDTree] = {}  # path -> KD-tree of the area its bodies sweep
        for (a, b), cp in conflicts.items():
            if a not in index or b not in index:
                continue
            p, q = index[a], index[b]
            kind[p, q] = KIND_CODE[cp.kind]
            s_a[p, q], s_b[p, q], x[p, q], y[p, q] = cp.s_a, cp.s_b, cp.x, cp.y
            if cp.kind == "cross":
                if b not in swept:
                    swept[b] = swept_area(paths[b], vehicle_length, vehicle_width)
                zone = conflict_zone(paths[a], paths[b], vehicle_length, vehicle_width, swept[b])
                if zone is None:  # centre lines within a width but outlines apart: the point itself
                    zone = point_zone(cp.s_a, vehicle_length, vehicle_width)
                zone_in[p, q], zone_out[p, q] = zone
        return cls(ids=ids, index=index, kind=kind, s_a=s_a, s_b=s_b, x=x, y=y,
                   zone_in=zone_in, zone_out=zone_out, body=(float(vehicle_length), float(vehicle_width)),
                   paths=dict(paths),
                   s_stop=np.array([paths[i].s_stop for i in ids]),
                   s_exit=np.array([paths[i].s_exit for i in ids]),
                   length=np.array([paths[i].length for i in ids]),
                   s_wait=np.array([paths[i].s_wait for i in ids], dtype=float))

    def indices(self, path_ids) -> np.ndarray:
        """Integer path indices of an iterable of path ids."""
        return np.array([self.index[p] for p in path_ids], dtype=np.intp)

    def counts(self) -> dict[str, int]:
        """Number of unordered pairs of distinct paths of each kind (self-pairs excluded)."""
        upper = self.kind[np.triu_indices(len(self.ids), 1)]
        return {name: int(np.sum(upper == code)) for code, name in enumerate(KIND_NAMES)}


@functools.lru_cache(maxsize=8)
def _load_conflict_table(net_file: str, vehicle_width: float, vehicle_length: float) -> ConflictTable:
    return ConflictTable.build(load_paths(net_file), _load_conflicts(net_file, vehicle_width),
                               vehicle_length, vehicle_width)


def load_conflict_table(net_file: str | FsPath, vehicle_width: float = 1.8,
                        vehicle_length: float = 4.5) -> ConflictTable:
    """:class:`ConflictTable` of the net, cached per (net file, width [m], length [m])."""
    return _load_conflict_table(str(net_file), float(vehicle_width), float(vehicle_length))


_MOVEMENT_CACHE: dict[tuple, object] = {}  # (kind, movements.key, sizes...) -> conflicts or table
_MOVEMENT_CACHE_SIZE = 16


def _cached(key: tuple, build):
    if key not in _MOVEMENT_CACHE:
        if len(_MOVEMENT_CACHE) >= _MOVEMENT_CACHE_SIZE:
            _MOVEMENT_CACHE.pop(next(iter(_MOVEMENT_CACHE)))  # the oldest entry
        _MOVEMENT_CACHE[key] = build()
    return _MOVEMENT_CACHE[key]


def movement_conflicts(movements: Movements, vehicle_width: float = 1.8) -> dict[tuple[str, str], ConflictPoint]:
    """:func:`conflict_points` of the movements' paths with SUMO's foes guarded, cached per
    (``movements.key``, width [m])."""
    width = float(vehicle_width)
    digest = inputs_digest("points", movements.paths, movements.foes, (width,))
    return _cached(("points", movements.key, width), lambda: disk_cached(
        digest, lambda: conflict_points(dict(movements.paths), width, movements.foes)))


def movement_conflict_table(movements: Movements, vehicle_width: float = 1.8,
                            vehicle_length: float = 4.5, touch_width: float | None = None) -> ConflictTable:
    """:class:`ConflictTable` of the movements, cached per (``movements.key``, width [m], length [m],
    touch width [m]). Its zones are for bodies ``vehicle_length`` x ``vehicle_width``; which
    paths conflict is decided with centre lines ``touch_width`` apart (default ``vehicle_width``;
    the widest vehicle type of a run, so two wide bodies on near paths are paired)."""
    width, length = float(vehicle_width), float(vehicle_length)
    touch = width if touch_width is None else float(touch_width)
    return _cached(("table", movements.key, width, length) + ((touch,) if touch != width else ()),
                   lambda: _shared_paths(disk_cached(
                       inputs_digest("table", movements.paths, movements.foes, (width, length, touch)),
                       lambda: _shared_paths(ConflictTable.build(dict(movements.paths), movement_conflicts(
                           movements, touch), length, width), None)), movements))


def _shared_paths(table: ConflictTable, movements: Movements | None) -> ConflictTable:
    """``table`` with its paths the movements' own objects (None: without, as it is stored on disk:
    the paths are its inputs, kept by the movements)."""
    object.__setattr__(table, "paths", None if movements is None else dict(movements.paths))  # frozen
    return table
