"""Collision risk at the predicted collision point, Gamma_cp (Eq. 9), and the event-triggered
mechanism (ETM, Eq. 39): a pair of vehicles plays a game when Gamma_cp^ij > Gamma_sf.

How Gamma_cp is evaluated here, and why
---------------------------------------
Eq. 9 sums the fields (Eq. 5) of the vehicles that meet at the predicted collision point. For
path-following vehicles that point is the precomputed conflict point of their two paths; it lies
on both centre lines, so each field is evaluated with lateral distance 0 and
``Gamma^k = Lambda^k(s) = a_k (s - v_k t_p)^2`` (Eq. 7), where s is the arc length from vehicle k
to the point along its path.

Taken literally (s = each vehicle's *current* distance to the point) the sum cannot tell a
dangerous pair from a harmless one: a vehicle right at the point contributes its full field
a v^2 t_p^2 whether the other one is a second or a minute away, and two vehicles that will pass the
point ten seconds apart score higher than two far-away vehicles that will arrive together. The
trigger must instead fire when both vehicles will reach the point *within the preview horizon*
and *close together in time*. Two choices give exactly that:

1. **Prediction horizon.** The trajectories are predicted over t_p only, so a collision point is
   predicted only when both vehicles reach it within t_p: TCP_i <= t_p and TCP_j <= t_p
   (TCP = distance / speed, Eqs. 21-22). A vehicle more than v t_p from the point, or one that
   has passed it by more than ``conflict_clearance`` (its body has left the point), gives no
   predicted collision and Gamma_cp = 0.
2. **Each field where the other vehicle is.** Vehicle k's field is evaluated at the point at the
   predicted moment the *other* vehicle m occupies it (TCP_m), i.e. with k's predicted distance
   to the point at that moment, ``s = d_k - v_k TCP_m = v_k (TCP_k - TCP_m)``. That is the risk
   each vehicle meets at the point from the other's field -- the use of the field in its source
   model (the field of one vehicle evaluated at another's position). The vehicle that arrives
   first has already passed when the second arrives (s < 0: no field behind a vehicle), so

       Gamma_cp = a_late v_late^2 (t_p - |TCP_i - TCP_j|)^2      for |TCP_i - TCP_j| <= t_p

   (both terms when they arrive at the same instant). It grows as the time gap shrinks, with the
   later vehicle's speed and with its aggressiveness, and is 0 for a gap of t_p or more.

A vehicle still on or less than ``conflict_clearance`` past the point counts as being at it
(TCP = 0).

Leader-follower pairs (a **following** conflict on a shared approach stretch, or a
**confluence** once one vehicle has passed the merge point and both are on the exit lane) have no
crossing to arrive at: the collision point is the leader's position, so Gamma_cp is the
follower's field there, ``Lambda_f(gap) = a_f v_f^2 (t_p - gap / v_f)^2`` -- the same expression
with the time headway in place of the time gap (the leader's field points away from the
follower). A following pair is dropped once the leader is more than ``conflict_clearance`` past
the end of the shared stretch. Unlike the paper's definition of a following conflict we do not
require the follower to be faster: a short headway is a risk even at equal speed, and J_log's own
gamma_log (Eq. 18) already ignores a leader that is pulling away.

Calibration of Gamma_sf (``ModelSettings.gamma_sf`` = 40, units a0 m^2): with the default
t_p = 4 s, a0 = 1 and kappa = 0.5 (a = 1.65) the trigger fires for arrival-time gaps below
4 - (40 / (1.65 v^2))^0.5 s: 3.0 s at 5 m/s, 3.5 s at 10 m/s, 2.4 s at 3 m/s; a vehicle slower
than (40 / (1.65 t_p^2))^0.5 = 1.2 m/s arriving second does not trigger it. In the paper's Case 1 A
at constant speed V1 reaches its conflict point with V2 0.42 s before V2 (Gamma_cp = 429) and the
one with V3 0.51 s before V3 (Gamma_cp = 502): each pair triggers as soon as its later vehicle is
within t_p of the point (V1 then about 3.5 s, 19 m, from it) and stays triggered until V1 has
cleared the point (tests/models/test_risk.py, also at t_p = 3 s). A higher Gamma_sf for the same
gap (165 keeps the 2 s gap at 5 m/s of t_p = 3 s) ends the game of Case 1 B as soon as its cautious
V2 slows down (the field grows with v^2 and exp(kappa)), and kappa no longer orders the min TTCs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.models.potential_field import preview_amplitude, preview_time
from intersection_cosim.models.prediction import PairConflicts, conflict_lookup
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflicts import KIND_CONFLUENCE, KIND_FOLLOWING


def gamma_cp(fields, axis: int = 0):
    """Gamma_cp = sum of the fields Gamma^i of the vehicles meeting at the point (Eq. 9)."""
    return np.sum(np.asarray(fields, float), axis=axis)


def collision_point_risk(d_i, v_i, kappa_i, d_j, v_j, kappa_j, settings: ModelSettings):
    """Gamma_cp (Eq. 9) of a cross / confluence point for pairs of vehicles, vectorised.

    ``d_i``, ``d_j`` [m] signed arc-length distances of each vehicle to the point along its own
    path (negative once past it), ``v`` [m/s] speeds, ``kappa`` [-] aggressiveness. See the module
    docstring for the evaluation: 0 unless both reach the point within t_p and neither has passed
    it by more than ``conflict_clearance``; otherwise the sum of each vehicle's field (lateral
    distance 0) at the moment the other one is at the point.
    """
    floor = settings.tcp_speed_floor
    d_i, d_j = np.asarray(d_i, float), np.asarray(d_j, float)
    reach_i, reach_j = np.maximum(d_i, 0.0), np.maximum(d_j, 0.0)
    t_i = time_to_conflict_point(reach_i, v_i, floor)  # [s] Eq. 21
    t_j = time_to_conflict_point(reach_j, v_j, floor)  # [s] Eq. 22
    field_i = preview_amplitude(reach_i - np.maximum(v_i, floor) * t_j, v_i, kappa_i, settings)
    field_j = preview_amplitude(reach_j - np.maximum(v_j, floor) * t_i, v_j, kappa_j, settings)
    clear = settings.conflict_clearance
    # each vehicle's own preview t_p^i (Eq. 7): the point is predicted when both reach it within theirs
    tp_i, tp_j = preview_time(kappa_i, settings), preview_time(kappa_j, settings)  # [s]
    predicted = (d_i >= -clear) & (d_j >= -clear) & (t_i <= tp_i) & (t_j <= tp_j)
    out = np.where(predicted, field_i + field_j, 0.0)
    return out if out.ndim else float(out)


def following_risk(gap, v_follower, kappa_follower, settings: ModelSettings):
    """Gamma_cp of a leader-follower pair: the follower's field at the leader, Lambda_f(gap)
    (Eqs. 7, 9); ``gap`` [m] arc-length distance between the two, ``v_follower`` [m/s]."""
    out = preview_amplitude(gap, v_follower, kappa_follower, settings)
    return out if np.ndim(out) else float(out)


@dataclass(frozen=True)
class PairRisk:
    """Risk of every conflicting vehicle pair (i < j) at one instant, and the ETM decision."""

    i: np.ndarray  # (M,) first vehicle of each pair
    j: np.ndarray  # (M,) second vehicle
    kind: np.ndarray  # (M,) int8 conflict kind code (network.conflicts.KIND_NAMES)
    s_cp_i: np.ndarray  # (M,) [m] conflict point's arc length on i's path
    s_cp_j: np.ndarray  # (M,) [m] conflict point's arc length on j's path
    x: np.ndarray  # (M,) [m] conflict point
    y: np.ndarray  # (M,) [m]
    tcp_i: np.ndarray  # (M,) [s] TCP of i, signed (negative once past; Eq. 21)
    tcp_j: np.ndarray  # (M,) [s] TCP of j (Eq. 22)
    leader_follower: np.ndarray  # (M,) bool: evaluated as a leader-follower pair
    gamma_cp: np.ndarray  # (M,) Gamma_cp (Eq. 9), units of a0 * m^2
    trigger: np.ndarray  # (M,) bool: Gamma_cp > Gamma_sf (Eq. 39)

    @property
    def triggered_pairs(self) -> np.ndarray:
        """(K, 2) vehicle index pairs for which a game is played."""
        return np.stack([self.i[self.trigger], self.j[self.trigger]], axis=1)


def event_trigger(table, path_idx, s, v, kappa, settings: ModelSettings, pairs=None,
                  conflicts: PairConflicts | None = None) -> PairRisk:
    """The ETM (Eq. 39) for N vehicles: Gamma_cp of every conflicting pair and whether it fires.

    ``table``: the net's :class:`~intersection_cosim.network.conflicts.ConflictTable`;
    ``path_idx`` (N,) each vehicle's path index in it; ``s`` (N,) [m] arc length along the path,
    ``v`` (N,) [m/s] speed, ``kappa`` (N,) aggressiveness; ``pairs`` optional (i, j) index arrays
    (default: all i < j). Pairs whose paths do not meet are not returned (and never trigger).
    ``conflicts``: the pairs' conflict points if already looked up with
    :func:`~intersection_cosim.models.prediction.conflict_lookup` (then ``pairs`` is ignored).
    Vectorised over pairs; see the module docstring for how Gamma_cp is evaluated.
    """
    s, v, kappa = (np.asarray(x, float) for x in (s, v, kappa))
    pc = conflict_lookup(table, path_idx, pairs) if conflicts is None else conflicts
    i, j, kind = pc.i, pc.j, pc.kind
    s_i, s_j, v_i, v_j, k_i, k_j = s[i], s[j], v[i], v[j], kappa[i], kappa[j]
    floor = settings.tcp_speed_floor
    d_i, d_j = pc.s_cp_i - s_i, pc.s_cp_j - s_j  # [m] signed distance to the point
    # Leader-follower: a following pair, or a confluence once one of them has passed the merge.
    leader_follower = (kind == KIND_FOLLOWING) | ((kind == KIND_CONFLUENCE) & (np.minimum(d_i, d_j) < 0.0))
    i_leads = d_i < d_j
    gap = np.abs(d_i - d_j)  # [m]
    follow = following_risk(gap, np.where(i_leads, v_j, v_i), np.where(i_leads, k_j, k_i), settings)
    on_stretch = (kind != KIND_FOLLOWING) | (np.minimum(d_i, d_j) >= -settings.conflict_clearance)
    follow = np.where(on_stretch, follow, 0.0)
    cross = collision_point_risk(d_i, v_i, k_i, d_j, v_j, k_j, settings)
    gamma = np.where(leader_follower, follow, cross)
    return PairRisk(i=i, j=j, kind=kind, s_cp_i=pc.s_cp_i, s_cp_j=pc.s_cp_j, x=pc.x, y=pc.y,
                    tcp_i=time_to_conflict_point(d_i, v_i, floor),
                    tcp_j=time_to_conflict_point(d_j, v_j, floor),
                    leader_follower=leader_follower, gamma_cp=gamma,
                    trigger=gamma > settings.gamma_sf)
