"""Vehicle roles of the paper's Section II, vectorised.

Absolute role of a vehicle, from its place relative to the conflict zone (CZ):
``ready`` (RV, approaching the CZ), ``passing`` (PV, inside it), ``outside`` (OV, has left it;
no longer part of any conflict).

Relative role of vehicle j for host vehicle i (HV): ``host`` (j is i), ``leading`` (LV: j drives
ahead of i on a stretch of lane they share), ``neighbour_conflict`` (NV: j comes from another
direction and has a conflict point with i that neither has passed yet), ``irrelevant`` (IV:
everything else, and every vehicle seen from an outside host).

Conflict type of a pair: the kind of the precomputed conflict point of their two paths
(``following`` / ``cross`` / ``confluence``, :mod:`intersection_cosim.network.conflicts`), or none.
"""

from __future__ import annotations

import numpy as np

from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflicts import (
    KIND_CONFLUENCE,
    KIND_CROSS,
    KIND_FOLLOWING,
    KIND_NAMES,
    KIND_NONE,
)
from intersection_cosim.network.paths import MovementPath

READY, PASSING, OUTSIDE = 0, 1, 2
ROLE_NAMES = ("ready", "passing", "outside")  # index = role code

IRRELEVANT, LEADING, NEIGHBOUR_CONFLICT, HOST = 0, 1, 2, 3
RELATIVE_ROLE_NAMES = ("irrelevant", "leading", "neighbour_conflict", "host")  # index = code


def role_codes(x, y, settings: ModelSettings) -> np.ndarray:
    """Role codes (READY / PASSING / OUTSIDE) from positions (x, y) [m], vectorised.

    Inside the square |x|, |y| <= ``settings.conflict_zone_half`` a vehicle is passing. Outside
    it, position alone says whether it is on an incoming or an outgoing lane, because the arms lie
    along the axes and traffic keeps right: on the south arm (y < 0, |y| > |x|) the incoming
    (northbound) lanes have x > 0, on the east arm y > 0, on the north arm x < 0, on the west arm
    y < 0. A point exactly on an arm's axis counts as outgoing. For a vehicle whose path is known,
    :func:`role_codes_from_arc_length` is the authoritative form.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    half = settings.conflict_zone_half
    inside = (np.abs(x) <= half) & (np.abs(y) <= half)
    vertical_arm = np.abs(y) >= np.abs(x)  # north / south arm
    # incoming iff the offset from the arm's axis lies to the right of the inward direction
    incoming = np.where(vertical_arm, x * np.sign(-y) > 0, y * np.sign(x) > 0)
    return np.where(inside, PASSING, np.where(incoming, READY, OUTSIDE)).astype(np.int8)


def role(x: float, y: float, settings: ModelSettings) -> str:
    """"ready" | "passing" | "outside" of a vehicle at (x, y) [m] (see :func:`role_codes`)."""
    return ROLE_NAMES[int(role_codes(x, y, settings))]


def role_codes_from_arc_length(s, s_stop, s_exit) -> np.ndarray:
    """Role codes from the arc length ``s`` [m] along each vehicle's path, vectorised: ready before
    the stop line (s < s_stop), passing inside the junction, outside once on the exit lane
    (s > s_exit). ``s_stop``, ``s_exit`` [m] broadcast (e.g. ``PathTable.s_stop[path_idx]``)."""
    s = np.asarray(s, float)
    return np.where(s < s_stop, READY, np.where(s <= s_exit, PASSING, OUTSIDE)).astype(np.int8)


def role_from_arc_length(s: float, path: MovementPath) -> str:
    """"ready" | "passing" | "outside" at arc length ``s`` [m] along ``path``."""
    return ROLE_NAMES[int(role_codes_from_arc_length(s, path.s_stop, path.s_exit))]


def conflict_types(table, path_idx) -> np.ndarray:
    """(N, N) conflict kind codes (``KIND_NAMES``) of every vehicle pair; the diagonal is none."""
    path_idx = np.asarray(path_idx, dtype=np.intp)
    kind = table.kind[path_idx[:, None], path_idx[None, :]].copy()
    np.fill_diagonal(kind, KIND_NONE)
    return kind


def conflict_type(table, path_a: str, path_b: str) -> str | None:
    """"following" | "cross" | "confluence" for two path ids, or None when they do not meet."""
    code = int(table.kind[table.index[path_a], table.index[path_b]])
    return KIND_NAMES[code] if code else None


def relative_roles(table, path_idx, s, settings: ModelSettings) -> np.ndarray:
    """(N, N) relative-role codes: entry [i, j] is vehicle j's role for host vehicle i.

    ``table``: the net's ConflictTable; ``path_idx`` (N,) path indices; ``s`` (N,) [m] arc lengths.
    With d = (conflict point's arc length) - s for each vehicle of a pair:

    - leading: j is ahead of i on a shared stretch -- a following pair (same approach lane) with
      s_j > s_i, while j is at most ``conflict_clearance`` past the end of the shared stretch;
      or a confluence pair once j has passed the merge point (d_j < 0) and is ahead (d_j < d_i);
    - neighbour_conflict: a cross pair that neither vehicle has passed by more than
      ``conflict_clearance``, or a confluence pair before either has reached the merge point;
    - host on the diagonal; irrelevant otherwise, and for an outside (OV) host.
    """
    path_idx = np.asarray(path_idx, dtype=np.intp)
    s = np.asarray(s, float)
    p, q = path_idx[:, None], path_idx[None, :]
    kind = table.kind[p, q]
    d_i = table.s_a[p, q] - s[:, None]  # host's distance to the point
    d_j = table.s_b[p, q] - s[None, :]  # other's distance to the point
    clear = settings.conflict_clearance
    with np.errstate(invalid="ignore"):
        leading = ((kind == KIND_FOLLOWING) & (s[None, :] > s[:, None]) & (d_j >= -clear)) | (
            (kind == KIND_CONFLUENCE) & (d_j < 0.0) & (d_j < d_i))
        neighbour = ((kind == KIND_CROSS) & (d_i >= -clear) & (d_j >= -clear)) | (
            (kind == KIND_CONFLUENCE) & (d_i >= 0.0) & (d_j >= 0.0))
    out = np.where(leading, LEADING, np.where(neighbour, NEIGHBOUR_CONFLICT, IRRELEVANT)).astype(np.int8)
    outside = role_codes_from_arc_length(s, table.s_stop[path_idx], table.s_exit[path_idx]) == OUTSIDE
    out[outside, :] = IRRELEVANT
    np.fill_diagonal(out, HOST)
    return out
