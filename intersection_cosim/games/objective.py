"""A player's cost over the horizon: the true value (from models.cost) and its convex model.

True cost of player i for its accelerations a (N,) and the other players' planned trajectories:

    C_i(a) = dt * sum_{k=1..N} [ J_i(x_k) + w_accel a_{k-1}^2 ] + dt * w_jerk * sum_k ((a_k - a_{k-1}) / dt)^2

with J_i = (1 - kappa) (k_log J_log + k_lat J_lat + k_lk J_lk) + kappa J_e (Eqs. 13-14) evaluated
at the N predicted states x_1..x_N (rectangle rule; x_0 is fixed and does not depend on a). The
value always comes from :mod:`intersection_cosim.models.cost`; the solvers use it to accept or
reject every step. J_lat of a cross / confluence interaction counts at step k while neither player
has passed its conflict point by more than ``conflict_clearance`` (its switch-off is a jump of the
true cost that no smooth model sees: the equilibrium checks find their largest gains there, by
clearing the point one step earlier). J_log counts for the follower of a following pair only.
J_lk is the constant ``Player.j_lk`` of the player's discrete lane choice. Each J_lat term with
another player is weighted by the risk that partner poses, exp(k_lat_partner (kappa_q - 0.5))
(:func:`~intersection_cosim.games.weights.partner_risk_weight`; 1 for a partner at kappa 0.5 and
for a human driver), times player i's own factor exp(-k_lat_own (kappa_i - 0.5))
(:func:`~intersection_cosim.games.weights.own_risk_weight`), and never below 1
(:func:`~intersection_cosim.games.weights.lateral_risk_weight`: no player takes a crossing less
seriously than Eq. 19 does).

Convex model (the "convexification" of the SQP): J_e and the comfort terms are quadratic in a
(speeds are affine in a) and enter exactly. J_lat (Eq. 19) and J_log (Eq. 15) are a scalar
function f of one TTC-like quantity per step:

* J_lat = f(g), f(g) = 1 / (g^2 + eps), g = TTC_lat = TCP_i - TCP_j (Eqs. 20-22);
* J_log = h(r), h(r) = r^2 / (1 + eps r^2) for r > 0 else 0, r = 1 / TTC_log = dv / gap
  (the same value as Eq. 15 with gamma of Eq. 18, written in the inverse TTC so that it is C^1
  where the follower stops closing in).

Gauss-Newton: g (or r) is linearised around the iterate, g ~ g0 + G (a - a0); the model keeps the
exact slope f'(g0) G and the curvature G^T max(f''(g0), 0) G, i.e. the negative curvature of f near
TTC_lat = 0 (|g| < sqrt(eps / 3)) and of h near contact (r^2 > 1 / (3 eps)) is dropped. The model is convex; the trust region and the line
search of the best response make up for what it ignores.
"""

from __future__ import annotations

import math

import numpy as np

from intersection_cosim.games.dynamics import horizon_matrices, state_offset, stay_behind
from intersection_cosim.games.problem import Plan, Player, Problem, speed_cap
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games import convex_model as cm
from intersection_cosim.games.true_cost import PARAMS, true_costs
from intersection_cosim.games.weights import comfort_weight, lateral_risk_weight, own_limits, quadratic_part
from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.models.settings import ModelSettings


EXOGENOUS = -1  # "other player" index of a non-player leader (Player.leader) in log_terms


def _rcumsum(x: np.ndarray) -> np.ndarray:
    """Reverse cumulative sum: out[m] = sum_{k >= m} x[k]."""
    return x[::-1].cumsum()[::-1]


def _length(length: float | None, ms: ModelSettings) -> float:
    """[m] a vehicle's body length: its own, else ModelSettings.vehicle_length."""
    return ms.vehicle_length if length is None else float(length)


def _terms(problem: Problem, p: int) -> tuple[list[tuple[int, float, float]], list[tuple[int, float]]]:
    """Player p's lateral terms (other, s_cp own [m], s_cp other [m]) and the following terms
    where p follows (leader, offset [m]), from the problem's interactions."""
    lat, log = [], []
    for it in problem.interactions:
        if it.lateral and it.i == p:
            lat.append((it.j, it.s_cp_i, it.s_cp_j))
        elif it.lateral and it.j == p:
            lat.append((it.i, it.s_cp_j, it.s_cp_i))
        elif it.kind == "following" and it.i == p:
            log.append((it.j, it.offset))
    return lat, log


class PlayerObjective:
    """Player ``p``'s cost as a function of its own accelerations, the others' plans held fixed.

    Build once per (problem, player); call :meth:`set_others` whenever the other players' plans
    change, then :meth:`cost` (true value) and :meth:`model` / :meth:`cost_and_model` (gradient
    and convex Hessian). Written for speed: no Python loop over the horizon, few numpy calls.
    """

    def __init__(self, problem: Problem, p: int, gs: GameSettings, ms: ModelSettings):
        pl: Player = problem.players[p]
        self.p, self.ms = p, ms
        self.gs = own_limits(gs, pl)  # the game's settings, its U^i (Eq. 11) narrowed to the player's own limits
        self.limited = self.gs is not gs  # [-] the player's bounds differ from the game's
        self.n, self.dt = gs.problem.steps, gs.problem.dt
        dt = self.dt
        self.hm = hm = horizon_matrices(self.n, dt)
        self.s0, self.v0, self.kappa = float(pl.s0), float(pl.v0), float(pl.kappa)
        self.v_max = float(pl.v_max if pl.v_max is not None else ms.v_max)  # [m/s]
        self.v_cap = speed_cap(pl, ms.v_max)  # [m/s]
        self.j_lk = float(pl.j_lk)
        self.s_free = self.s0 + self.v0 * hm.t  # [m] positions at zero acceleration
        self._offset = state_offset(self.s0, self.v0, hm)  # (v_0..v_N, s_0..s_N) at a = 0
        self._n1 = self.n + 1
        self.w_lat = dt * (1.0 - self.kappa) * ms.k_lat  # [s] weight of J_lat per step
        self.w_log = dt * (1.0 - self.kappa) * ms.k_log  # [s] weight of J_log per step
        self.w_e = dt * self.kappa * ms.k_e  # [s^3/m^2] weight of (v - v_max)^2 per step
        self.jerk_w = gs.problem.w_jerk / (dt * dt)  # [s^4/m^2] weight of (a_k - a_{k-1})^2
        self.w_acc = comfort_weight(gs.problem, self.kappa)  # [s^4/m^2] weight of a^2
        self._floor, self._clr, self._eps = ms.tcp_speed_floor, ms.conflict_clearance, ms.eps
        self.lat_terms, self.log_terms = _terms(problem, p)
        # [m] each player's body (J_log's gap to a leading player is bumper to bumper, Eq. 16)
        self._lengths = [_length(q.length, ms) for q in problem.players]
        self._exo = None  # a non-player leader (Player.leader): (s - length, v) over the horizon
        if pl.leader is not None:
            s_l, v_l = (np.asarray(x, dtype=float) for x in pl.leader)
            if s_l.shape != (self.n,) or v_l.shape != (self.n,):
                raise ValueError(f"player {p}: leader trajectory must have {self.n} steps")
            self.log_terms.append((EXOGENOUS, 0.0))
            self._exo = (s_l - _length(pl.leader_length, ms), v_l)
        # crossing non-players (Player.crossers, human drivers: partners at kappa 0.5): their J_lat
        # data is fixed, computed once
        human = lateral_risk_weight(self.kappa, 0.5, ms)  # [-]
        self._lat_fixed = [self._lateral_data(scp, scp_q, s_q, v_q, human) for scp, scp_q, s_q, v_q in pl.crossers]
        # [-] per lateral term with a player: the weight of the risk that partner poses
        self._lat_weight = [lateral_risk_weight(self.kappa, problem.players[q].kappa, ms) for q, _, _ in self.lat_terms]
        if self.w_lat <= 0.0:
            self.lat_terms, self._lat_fixed = [], []
        if self.w_log <= 0.0:
            self.log_terms = []
        # exact quadratic part (efficiency + comfort): 1/2 a^T Q a + b0^T a + const
        self.Q = quadratic_part(self.n, dt, self.w_e, self.w_acc, self.jerk_w)
        self.b0 = (2.0 * self.w_e * (self.v0 - self.v_max)) * hm.dtLv_colsum
        # per lateral term (lat_terms, then the fixed crossers): (s_cp own, TCP of the other (N,),
        # other not passed (N,))
        self._lat: list = list(self._lat_fixed)
        # the players whose plans set_others reads, and the Plans it installed last (None: none yet)
        self._partners = tuple(q for q, _, _ in self.lat_terms) + tuple(q for q, _ in self.log_terms if q != EXOGENOUS)
        self._installed: tuple | None = None
        self._log: list = []  # per following term: (leader s in own frame minus length (N,), leader v (N,))
        if self._exo is not None and self.log_terms and not self.lat_terms and len(self.log_terms) == 1:
            self._log = [self._exo]  # nothing else to wait for: usable before set_others
        values = {"dt": dt, "kappa": self.kappa, "k_log": ms.k_log, "k_lat": ms.k_lat, "k_lk": ms.k_lk,
                  "k_e": ms.k_e, "j_lk": self.j_lk, "v_max": self.v_max, "w_acc": self.w_acc,
                  "jerk_w": self.jerk_w, "eps": self._eps, "speed_floor": self._floor, "clearance": self._clr}
        self._params = np.array([values[k] for k in PARAMS], dtype=float)  # of true_costs
        values.update(w_lat=self.w_lat, w_log=self.w_log, gap_floor=self.gs.solver.gap_floor)
        self._model_params = np.array([values[k] for k in cm.PARAMS], dtype=float)  # of convex_model
        self._stack: tuple | None = None  # (_lat, _log, their arrays for true_costs)

    @property
    def coupled(self) -> bool:
        """True when the cost depends on other players (the model is then only an approximation)."""
        return bool(self.lat_terms or self.log_terms or self._lat_fixed)

    # ------------------------------------------------------------------ data of the others
    def set_others(self, plans) -> None:
        """``plans[q]`` is player q's Plan (entries of players without a term are ignored).

        Plans are immutable: when every partner's Plan is the object installed by the last call,
        the data are those already installed and are kept (a Stackelberg iteration installs the
        same plans twice in a row in half its calls)."""
        partners = tuple(plans[q] for q in self._partners)
        if self._installed is not None and all(x is y for x, y in zip(partners, self._installed)):
            return
        self._installed = partners
        self._lat = [self._lateral_data(scp, scp_q, plans[q].positions[1:], plans[q].speeds[1:], w)
                     for (q, scp, scp_q), w in zip(self.lat_terms, self._lat_weight)] + self._lat_fixed
        self._log = []
        for q, offset in self.log_terms:
            if q == EXOGENOUS:
                self._log.append(self._exo)
                continue
            self._log.append((plans[q].positions[1:] + (offset - self._lengths[q]),
                              plans[q].speeds[1:]))

    def _lateral_data(self, scp: float, scp_q: float, s_q: np.ndarray, v_q: np.ndarray,
                      weight: float = 1.0) -> tuple:
        """J_lat data of one crossing: (s_cp own [m], the other's TCP (N,) [s] (Eqs. 21-22), the
        other not yet past its point by conflict_clearance (N,): bool, or the term's ``weight``
        [-] (:func:`lateral_risk_weight`) there and 0 after) from its positions ``s_q`` [m] and
        speeds ``v_q`` [m/s] over the horizon."""
        open_q = (s_q - scp_q) <= self._clr
        return (scp, time_to_conflict_point(scp_q - s_q, v_q, self._floor),
                open_q if weight == 1.0 else weight * open_q)

    def plan(self, a: np.ndarray, duals: np.ndarray | None = None) -> Plan:
        """The player's Plan for accelerations ``a`` (N,)."""
        full = self.hm.M @ a + self._offset
        return Plan(a, full[:self._n1], full[self._n1:], self.dt, duals)

    def _vs(self, a):
        """v_1..v_N, s_1..s_N for a (N,) or (m, N)."""
        n1 = self._n1
        full = (self.hm.M @ a if a.ndim == 1 else a @ self.hm.M.T) + self._offset
        return full[..., 1:n1], full[..., n1 + 1:]

    def keep_behind(self, a: np.ndarray) -> np.ndarray:
        """[m/s^2] ``a`` changed, if needed, so the player stays behind every leader's planned
        position (gap >= 0): a starting plan for the best response. J_log (Eq. 15) has no barrier
        at contact (its largest value is 1 / eps at TTC = 0 and it falls again for a negative
        gap), so a local search started from a plan that already overlaps its leader can settle
        on driving through it; from behind, reaching the leader means climbing to 1 / eps."""
        if not self._log:
            return a
        v, s = self._vs(a)
        bound = self._log[0][0] if len(self._log) == 1 else np.minimum.reduce([b for b, _ in self._log])
        if (s <= bound).all():
            return a
        return stay_behind(a, self.s0, self.v0, bound, self.dt, self.gs.problem.a_min)

    # ------------------------------------------------------------------ true cost
    def cost(self, a) -> np.ndarray | float:
        """[-] true cost C_p(a) (module docstring); ``a`` of shape (N,) or (m, N): a float or (m,)
        (games.true_cost, compiled)."""
        a = np.asarray(a, dtype=float)
        rows = true_costs(np.ascontiguousarray(a if a.ndim == 2 else a[None]), self.hm.M, self._offset,
                          *self._stacked(), self._params)
        return float(rows[0]) if a.ndim == 1 else rows

    def _stacked(self) -> tuple:
        """The lateral and following terms' data as the arrays :func:`true_costs` takes, built
        once per :meth:`set_others` that changed them."""
        if self._stack is None or self._stack[0] is not self._lat or self._stack[1] is not self._log:
            n = self.n
            lat = (np.array([t[0] for t in self._lat], dtype=float),
                   np.array([t[1] for t in self._lat], dtype=float).reshape(-1, n),
                   np.array([t[2] for t in self._lat], dtype=float).reshape(-1, n))
            log = (np.array([t[0] for t in self._log], dtype=float).reshape(-1, n),
                   np.array([t[1] for t in self._log], dtype=float).reshape(-1, n))
            self._stack = (self._lat, self._log, lat + log)
        return self._stack[2]

    # ------------------------------------------------------------------ convex model
    def cost_and_model(self, a: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """True cost, gradient (N,) and convex Gauss-Newton Hessian (N, N) at ``a`` (N,)."""
        grad, H = self.model(a)
        return self.cost(a), grad, H

    def model(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gradient (N,) and convex Gauss-Newton Hessian (N, N) of C_p at ``a`` (games.convex_model,
        compiled)."""
        hm = self.hm
        return cm.convex_model(np.ascontiguousarray(a, dtype=float), hm.M, self._offset, self.Q, self.b0,
                               hm.k_half, hm.m_dt2, *self._stacked(), self._model_params)

    def cost_and_gradient(self, a: np.ndarray) -> tuple[float, np.ndarray]:
        """True cost and its gradient (N,) where smooth, without forming any N x N matrix.

        The Jacobians of :meth:`model` are lower-triangular with rows affine in the column index,
        so G^T w reduces to reverse cumulative sums.
        """
        hm, dt = self.hm, self.dt
        v, s = self._vs(a)
        grad = self.Q @ a + self.b0
        if self._lat:
            eps = self._eps
            inv = 1.0 / np.maximum(v, self._floor)
            for scp, tcp_q, open_q in self._lat:
                d = scp - s
                tcp = time_to_conflict_point(d, v, self._floor)
                active = (s <= scp + self._clr) * open_q
                if active.any():
                    g = tcp - tcp_q
                    den = g * g + eps
                    w1 = (self.w_lat * active) * (-2.0 * g) / (den * den)
                    c = (d * inv * inv) * (v > self._floor) * dt
                    alpha = inv * hm.k_half + c
                    grad += hm.m_dt2 * _rcumsum(inv * w1) - _rcumsum(alpha * w1)
        for s_lead, v_lead in self._log:
            gap = np.maximum(s_lead - s, self.gs.solver.gap_floor)
            dv = v - v_lead
            r = dv / gap
            closing = r > 0
            if closing.any():
                den = 1.0 + self._eps * r * r
                w1 = (self.w_log * closing) * 2.0 * r / (den * den)
                x = dv / (gap * gap) * w1
                grad += dt * _rcumsum(w1 / gap) + _rcumsum(hm.k_half * x) - hm.m_dt2 * _rcumsum(x)
        return self.cost(a), grad

    def gradient(self, a: np.ndarray) -> np.ndarray:
        """Gradient of the true cost where it is smooth (N,)."""
        return self.cost_and_gradient(a)[1]

    def _lateral_jacobian(self, d, v, inv):
        """dTCP/da (N, N) for TCP = d / max(v, floor): row k = -(Ls[k] + d_k / v_k dtLv[k]) / v_k."""
        hm = self.hm
        c = (d * inv * inv) * (v > self._floor) * self.dt
        # Ls[k, m] = k_half[k] - m_dt2[m] and Lv[k, m] = 1 for m <= k
        alpha = inv * hm.k_half + c
        return (np.multiply.outer(inv, hm.m_dt2) - alpha[:, None]) * hm.Lv

    def _lateral_weights(self, g, active) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-Newton weights of sum_k w_lat f(g_k), f(g) = 1 / (g^2 + eps) (Eq. 19): the slope
        w f'(g) and the convex part of the curvature w max(f''(g), 0), per step."""
        eps = self._eps
        gg = g * g
        den = gg + eps
        den2 = den * den
        w = self.w_lat * active
        return w * (-2.0 * g) / den2, w * np.maximum((6.0 * gg - 2.0 * eps) / (den2 * den), 0.0)

    def _following_jacobian(self, gap, dv):
        """d(1 / TTC_log)/da (N, N) for r = dv / gap."""
        hm = self.hm
        return (self.dt / gap)[:, None] * hm.Lv + (dv / (gap * gap))[:, None] * hm.Ls

    def _following_terms(self, s_lead, v_lead, v, s):
        """Jacobian R = dr/da and the Gauss-Newton weights (slope, convex curvature) of
        sum_k w_log h(r_k), h(r) = r^2 / (1 + eps r^2) (Eq. 15), r = 1 / TTC_log; None when the
        player closes in on its leader at no step."""
        gap = np.maximum(s_lead - s, self.gs.solver.gap_floor)
        dv = v - v_lead
        r = dv / gap
        closing = r > 0
        if not closing.any():
            return None
        eps = self._eps
        den = 1.0 + eps * r * r
        den2 = den * den
        w = self.w_log * closing
        return (self._following_jacobian(gap, dv), w * 2.0 * r / den2,
                w * np.maximum((2.0 - 6.0 * eps * r * r) / (den2 * den), 0.0))

    # ------------------------------------------------------------------ pair model (Stackelberg)
    def pair_model(self, a: np.ndarray, q: int, plan_q, partner_curvature: bool = True) -> tuple[np.ndarray, ...]:
        """Convex model of C_p in (a_p, a_q) jointly.

        Returns grad_p (N,), grad_q (N,), H_pp, H_pq, H_qq (N, N): the Gauss-Newton model
        J^T diag(max(f'', 0)) J with J = [dg/da_p, dg/da_q] for each term coupling p with q, plus
        p's exact quadratic terms and its terms with other players in H_pp. ``plan_q`` must be
        the plan of q installed by :meth:`set_others`. With ``partner_curvature=False`` grad_q
        and H_qq are returned as None (the Stackelberg follower's model needs neither).
        """
        n, hm = self.n, self.hm
        grad_p = self.Q @ a + self.b0
        H_pp = self.Q.copy()
        grad_q = np.zeros(n)
        H_pq = np.zeros((n, n))
        H_qq = np.zeros((n, n))
        v, s = self.v0 + hm.dtLv @ a, self.s_free + hm.Ls @ a
        v_q, s_q = plan_q.speeds[1:], plan_q.positions[1:]
        terms = []
        if self._lat:
            inv = 1.0 / np.maximum(v, self._floor)
            inv_q = 1.0 / np.maximum(v_q, self._floor)
            fixed = [(EXOGENOUS, math.nan, math.nan)] * len(self._lat_fixed)  # never q
            for (other, _scp, scp_q), (scp, tcp_q, open_q) in zip(self.lat_terms + fixed, self._lat):
                d = scp - s
                active = (s <= scp + self._clr) * open_q
                if not active.any():
                    continue
                g = d * inv - tcp_q
                G = self._lateral_jacobian(d, v, inv)
                # g = TCP_p - TCP_q, so dg/da_q = -dTCP_q/da_q
                Gq = -self._lateral_jacobian(scp_q - s_q, v_q, inv_q) if other == q else None
                terms.append((G, Gq, *self._lateral_weights(g, active)))
        for (other, _off), (s_lead, v_lead) in zip(self.log_terms, self._log):
            following = self._following_terms(s_lead, v_lead, v, s)
            if following is None:
                continue
            R, w1, w2 = following
            # r depends on the leader through -dv and +gap: dr/da_leader = -R (same time grid)
            terms.append((R, -R if other == q else None, w1, w2))
        for G, Gq, w1, w2 in terms:
            grad_p += G.T @ w1
            GW = G.T * w2
            H_pp += GW @ G
            if Gq is not None:
                H_pq += GW @ Gq
                if partner_curvature:
                    grad_q += Gq.T @ w1
                    H_qq += (Gq.T * w2) @ Gq
        if not partner_curvature:
            return grad_p, None, H_pp, H_pq, None
        return grad_p, grad_q, H_pp, H_pq, H_qq
