"""All movement paths stacked into padded numpy arrays, for vectorised look-ups by path index.

``MovementPath.point_at`` works on one path; the run-time code (prediction, roles, risk) needs the
point, heading or curvature of N vehicles on N different paths at once. Every path is resampled at
a uniform arc-length step (``paths.RESAMPLE_STEP``, slightly adjusted per path so it divides the
length), so the sample index of an arc length is ``s / ds`` and a look-up is one gather plus a
linear interpolation. Path order is the order of the ``paths`` dict, the same as in
:class:`~intersection_cosim.network.conflicts.ConflictTable`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from intersection_cosim.network.paths import MovementPath


@dataclass(frozen=True)
class PathTable:
    ids: tuple[str, ...]
    index: dict[str, int] = field(repr=False)
    ds: np.ndarray = field(repr=False)  # (P,) [m] arc-length step of each path's samples
    n: np.ndarray = field(repr=False)  # (P,) number of samples of each path
    length: np.ndarray = field(repr=False)  # (P,) [m]
    s_stop: np.ndarray = field(repr=False)  # (P,) [m] arc length of the stop line
    s_exit: np.ndarray = field(repr=False)  # (P,) [m] arc length where the exit lane starts
    xy: np.ndarray = field(repr=False)  # (P, n_max, 2) [m], padded with the last point
    heading: np.ndarray = field(repr=False)  # (P, n_max) [rad], padded
    curvature: np.ndarray = field(repr=False)  # (P, n_max) [1/m], padded
    packed: np.ndarray = field(repr=False)  # (P * n_max, 4) [x, y, heading, curvature] rows, for take()

    @classmethod
    def build(cls, paths: dict[str, MovementPath]) -> PathTable:
        ids = tuple(paths)
        n = np.array([len(paths[i].s) for i in ids])
        n_max = int(n.max())
        xy = np.empty((len(ids), n_max, 2))
        heading = np.empty((len(ids), n_max))
        curvature = np.empty((len(ids), n_max))
        for k, pid in enumerate(ids):
            p = paths[pid]
            m = len(p.s)
            xy[k, :m], xy[k, m:] = p.xy, p.xy[-1]
            heading[k, :m], heading[k, m:] = p.heading, p.heading[-1]
            curvature[k, :m], curvature[k, m:] = p.curvature, p.curvature[-1]
        length = np.array([paths[i].length for i in ids])
        packed = np.concatenate([xy, heading[..., None], curvature[..., None]], axis=2).reshape(-1, 4)
        return cls(ids=ids, index={pid: k for k, pid in enumerate(ids)}, ds=length / (n - 1), n=n,
                   length=length, s_stop=np.array([paths[i].s_stop for i in ids]),
                   s_exit=np.array([paths[i].s_exit for i in ids]), xy=xy, heading=heading,
                   curvature=curvature, packed=np.ascontiguousarray(packed))

    def indices(self, path_ids) -> np.ndarray:
        """Integer path indices of an iterable of path ids."""
        return np.array([self.index[p] for p in path_ids], dtype=np.intp)

    def _locate(self, path_idx, s):
        path_idx = np.asarray(path_idx, dtype=np.intp)
        u = np.clip(s, 0.0, self.length[path_idx]) / self.ds[path_idx]
        k = np.minimum(np.floor(u).astype(np.intp), self.n[path_idx] - 2)
        return path_idx, k, (u - k)

    def point_at(self, path_idx, s) -> np.ndarray:
        """[m] (x, y) at arc length ``s`` [m] on path ``path_idx`` (broadcast), shape (..., 2)."""
        p, k, f = self._locate(*np.broadcast_arrays(path_idx, s))
        f = f[..., None]
        return self.xy[p, k] * (1.0 - f) + self.xy[p, k + 1] * f

    def heading_at(self, path_idx, s) -> np.ndarray:
        """[rad] heading at arc length ``s`` [m] on path ``path_idx`` (broadcast)."""
        p, k, f = self._locate(*np.broadcast_arrays(path_idx, s))
        return self.heading[p, k] * (1.0 - f) + self.heading[p, k + 1] * f

    def curvature_at(self, path_idx, s) -> np.ndarray:
        """[1/m] signed curvature at arc length ``s`` [m] on path ``path_idx`` (broadcast)."""
        p, k, f = self._locate(*np.broadcast_arrays(path_idx, s))
        return self.curvature[p, k] * (1.0 - f) + self.curvature[p, k + 1] * f

    def sample(self, path_idx, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Point (..., 2) [m], heading [rad] and curvature [1/m] at arc length ``s`` [m] on path
        ``path_idx`` (broadcast): one index computation and two gathers (the hot path of the
        prediction)."""
        p, k, f = self._locate(*np.broadcast_arrays(path_idx, s))
        row = p * self.xy.shape[1] + k
        f = f[..., None]
        out = np.take(self.packed, row, axis=0) * (1.0 - f) + np.take(self.packed, row + 1, axis=0) * f
        return out[..., :2], out[..., 2], out[..., 3]

    def steer_at(self, path_idx, s, wheelbase: float) -> np.ndarray:
        """[rad] front-wheel steer the path implies, delta_f = atan(l * curvature) (Eqs. 1-4)."""
        return np.arctan(wheelbase * self.curvature_at(path_idx, s))
