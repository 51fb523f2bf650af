"""Solo best responses of many vehicles in one pass: the vehicles in no game.

A vehicle in no game minimises its own cost against its leader's predicted trajectory (J_log of
Eqs. 15-18 and J_e of Eq. 24 in the running cost of Eqs. 13-14, with the comfort terms of
:mod:`intersection_cosim.games.objective`). :func:`~intersection_cosim.games.nash.solo_response`
solves one such problem at a time; most of its time is Python around small numpy calls. Here the
problems of a control step are stacked: true costs, gradients and Gauss-Newton Hessians come from
the compiled kernels PlayerObjective uses (:mod:`~intersection_cosim.games.true_cost`,
:mod:`~intersection_cosim.games.convex_model`), one call for all rows with each vehicle's own
data; bounds, the line search and the trust-region logic are computed for all vehicles at once
as (m, N) arrays; so are the QPs' exact answers (no bound or only input bounds active: one
compiled call for all, :meth:`~intersection_cosim.games.qp.QPWorkspace.exact_many`), and only
the QPs those miss go to OSQP, one call per vehicle (the workspace slot ``("nash", 0)`` that
``solo_response`` uses; :mod:`intersection_cosim.games.qp`). The SQP is the one of
:mod:`intersection_cosim.games.sqp` (model QP in a trust region, Armijo line search on the true
cost, radius update) and the iteration the one of ``solo_response`` (``nash_max_iter`` SQP
steps, residual and cost-gain tests of :mod:`intersection_cosim.games.nash`), with two
differences, both within the solvers' tolerances: every iteration builds a fresh model Hessian
(``solo_response`` may reuse the last one within ``hessian_refresh``; only matters for
``nash_max_iter`` > 1), and each QP installs its own Hessian: ``solo_response`` in a shared
workspace may keep the P another vehicle installed (within ``hessian_reuse_tol`` in max norm,
which the small comfort terms pass whatever their weight), and with a capped SQP that QP's answer
is the plan (on random solo problems up to 30 % above the optimum of an exact QP).

Problems that are not a single player without interactions, or whose player crosses human
drivers (``Player.crossers``), go to ``solo_response`` one by one. So do the problems of a
batch smaller than ``SMALL_BATCH``, with ``own_hessian`` (the batch's two differences above):
the stacked arrays cost a fixed ~0.3 ms a batch, more than they save on a few vehicles
(``scripts/bench_solo_batch.py``: one by one is faster up to four problems, level at five); the
answers agree to rounding (``tests/games/test_solo_batch.py``). Never raises on numerical
trouble: a vehicle whose QP or cost fails gets the comfortable-braking plan with status
"solver failure", and the other vehicles are unaffected.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from intersection_cosim.games import convex_model, true_cost
from intersection_cosim.games.dynamics import horizon_matrices, state_offset, stay_behind
from intersection_cosim.games.nash import WarmStart, failure_result, solo_response, warm_list
from intersection_cosim.games.weights import comfort_weight, own_limits, quadratic_part
from intersection_cosim.games.problem import GameResult, Plan, Problem, project_accelerations, speed_cap
from intersection_cosim.games.qp import workspace
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.sqp import new_radius
from intersection_cosim.models.settings import ModelSettings

SMALL_BATCH = 6  # [-] fewer batchable problems than this are solved one by one (module docstring)


def batchable(problem: Problem) -> bool:
    """Whether :func:`solo_responses` solves ``problem`` in the batch (one player, no
    interaction, no crossing human)."""
    return problem.n == 1 and not problem.interactions and not problem.players[0].crossers


def solo_responses(problems: Sequence[Problem], settings: GameSettings | None = None,
                   model_settings: ModelSettings | None = None,
                   warm_starts: Sequence[WarmStart] | None = None) -> list[GameResult]:
    """``solo_response(problems[i], ..., warm_start=warm_starts[i])`` for every i (module
    docstring), in order; ``warm_starts[i]``: solo_response's warm start (a one-plan sequence:
    its accelerations and QP duals) or None (then the decoupled start of Eq. 33, one extra SQP
    step from zero acceleration)."""
    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    warm = list(warm_starts) if warm_starts is not None else [None] * len(problems)
    out: list[GameResult | None] = [None] * len(problems)
    rows = []
    for i, problem in enumerate(problems):
        if batchable(problem) and not problem.validate():
            rows.append(i)
        else:  # validation failures and other problems: the one-by-one solver says why
            out[i] = solo_response(problem, gs, ms, warm_start=warm[i])
    if 0 < len(rows) < SMALL_BATCH:
        for i in rows:
            out[i] = solo_response(problems[i], gs, ms, warm_start=warm[i], own_hessian=True)
    elif rows:
        t0 = time.perf_counter()
        batch = SoloBatch([problems[i].players[0] for i in rows], gs, ms)
        results = batch.solve([warm_list(warm[i], 1)[0] for i in rows])
        share = (time.perf_counter() - t0) / len(rows)  # [s] wall time per problem
        for i, (plan, cost, residuals, qps, failure) in zip(rows, results):
            if failure is not None:
                out[i] = failure_result(problems[i], gs, "nash", time.perf_counter() - share, failure, qps)
                continue
            status = "converged" if residuals[-1][1] else "iteration cap"
            res = tuple(r for r, _ in residuals)
            out[i] = GameResult((plan,), np.array([cost]), res, np.zeros((0, 1)), len(res), qps, status,
                                "nash", share)
    return out


@dataclass
class _Rows:
    """The iterate of the rows being solved: accelerations (m, N) [m/s^2], true costs (m,) [-],
    trust-region radii (m,) [m/s^2], QP duals to warm-start with (None: the slot's), the last
    QP's duals, QPs solved (m,), and the failure message per row (None: fine)."""

    a: np.ndarray
    cost: np.ndarray
    delta: np.ndarray
    duals: list
    y: list
    qps: np.ndarray
    failure: list


class SoloBatch:
    """m one-player problems of the same horizon as stacked arrays (module docstring)."""

    def __init__(self, players: Sequence, gs: GameSettings, ms: ModelSettings):
        self.gs, self.ms, self.m = gs, ms, len(players)
        self.n, self.dt = n, dt = gs.problem.steps, gs.problem.dt
        self.hm = hm = horizon_matrices(n, dt)
        self.players = list(players)
        self.limits = [own_limits(gs, p) for p in players]  # each player's U^i (Eq. 11)
        f = np.array
        self.s0, self.v0 = f([p.s0 for p in players], float), f([p.v0 for p in players], float)
        self.kappa = f([p.kappa for p in players], float)
        self.v_max = f([p.v_max if p.v_max is not None else ms.v_max for p in players], float)  # [m/s]
        self.v_cap = f([speed_cap(p, ms.v_max) for p in players], float)  # [m/s]
        self.a_lo = f([g.problem.a_min for g in self.limits])  # [m/s^2]
        self.a_hi = f([g.problem.a_max for g in self.limits])  # [m/s^2]
        self.w_e = dt * self.kappa * ms.k_e  # [s^3/m^2] weight of (v - v_max)^2 per step
        self.w_log = dt * (1.0 - self.kappa) * ms.k_log  # [s] weight of J_log per step
        self.w_acc = f([comfort_weight(gs.problem, float(k)) for k in self.kappa])  # [s^4/m^2]
        self.jerk_w = gs.problem.w_jerk / (dt * dt)  # [s^4/m^2]
        self.Q = np.stack([quadratic_part(n, dt, float(we), float(wa), self.jerk_w)
                           for we, wa in zip(self.w_e, self.w_acc)])
        self.b0 = (2.0 * self.w_e * (self.v0 - self.v_max))[:, None] * hm.dtLv_colsum
        self._leaders(players)
        self.s_free = self.s0[:, None] + self.v0[:, None] * hm.t  # [m] positions at a = 0
        self.sum_lo, self.sum_hi = -self.v0 / dt, (self.v_cap - self.v0) / dt  # [m/s^2] bounds of cumsum(a)
        self._kernel_data(players)

    def _kernel_data(self, players) -> None:
        """The rows' data as games.true_cost and games.convex_model take them: the offsets of the
        map a -> (v_0..v_N, s_0..s_N) (m, 2N + 2), the one following term (m, 1, N) each and the
        scalar parameters per row."""
        n, ms = self.n, self.ms
        self.offsets = np.empty((self.m, 2 * n + 2))
        self.offsets[:, :n + 1] = self.v0[:, None]
        self.offsets[:, n + 1] = self.s0
        self.offsets[:, n + 2:] = self.s_free
        self.log_s, self.log_v = self.bound.reshape(self.m, 1, n), self.v_lead.reshape(self.m, 1, n)
        rows = {"dt": self.dt, "kappa": self.kappa, "k_log": ms.k_log, "k_lat": ms.k_lat, "k_lk": ms.k_lk,
                "k_e": ms.k_e, "j_lk": np.array([p.j_lk for p in players], float), "v_max": self.v_max,
                "w_acc": self.w_acc, "jerk_w": self.jerk_w, "eps": ms.eps, "speed_floor": ms.tcp_speed_floor,
                "clearance": ms.conflict_clearance, "w_lat": self.dt * (1.0 - self.kappa) * ms.k_lat,
                "w_log": self.w_log, "gap_floor": self.gs.solver.gap_floor}
        self.cost_params = np.column_stack([np.broadcast_to(rows[k], self.m) for k in true_cost.PARAMS])
        self.model_params = np.column_stack([np.broadcast_to(rows[k], self.m) for k in convex_model.PARAMS])

    def _leaders(self, players) -> None:
        """J_log data: ``lead`` (m,) whether the row follows a leader with J_log weight > 0 (as
        PlayerObjective: no term at kappa = 1), its rear ``bound`` (m, N) [m] and speeds (m, N)."""
        self.bound = np.full((self.m, self.n), np.inf)
        self.v_lead = np.zeros((self.m, self.n))
        self.lead = np.zeros(self.m, bool)
        for i, p in enumerate(players):
            if p.leader is None or self.w_log[i] <= 0.0:
                continue
            s_l, v_l = (np.asarray(x, dtype=float) for x in p.leader)
            if s_l.shape != (self.n,) or v_l.shape != (self.n,):
                raise ValueError(f"player {p.name}: leader trajectory must have {self.n} steps")
            length = self.ms.vehicle_length if p.leader_length is None else float(p.leader_length)
            self.bound[i], self.v_lead[i], self.lead[i] = s_l - length, v_l, True

    # ------------------------------------------------------------------ values
    def _vs(self, a: np.ndarray, r: np.ndarray):
        """[m/s], [m]: v_1..v_N, s_1..s_N of rows ``r`` for accelerations ``a`` (len(r), N)."""
        return self.v0[r, None] + a @ self.hm.dtLv.T, self.s_free[r] + a @ self.hm.Ls.T

    def cost(self, a: np.ndarray, r: np.ndarray) -> np.ndarray:
        """[-] true costs (len(r),) of rows ``r`` (objective.py's C_i with J_log, J_e, J_lk and
        the comfort terms; Eqs. 13-18, 24; games.true_cost, compiled)."""
        return true_cost.solo_true_costs(np.ascontiguousarray(a, dtype=float), np.asarray(r, np.intp), self.hm.M,
                                         self.offsets, self.log_s, self.log_v, self.cost_params)

    def model(self, a: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gradients (len(r), N) and convex Gauss-Newton Hessians (len(r), N, N) of rows ``r``
        (PlayerObjective.model: J_e and comfort exact, J_log through r = 1 / TTC_log;
        games.convex_model, compiled)."""
        hm = self.hm
        return convex_model.solo_convex_models(np.ascontiguousarray(a, dtype=float), np.asarray(r, np.intp), hm.M,
                                               self.offsets, self.Q, self.b0, hm.k_half, hm.m_dt2, self.log_s,
                                               self.log_v, self.model_params)

    # ------------------------------------------------------------------ starts
    def start(self, warm: Sequence[Plan | None], r: np.ndarray) -> tuple[np.ndarray, list]:
        """Feasible start accelerations of rows ``r`` (sqp.initial_accelerations) and their duals."""
        a = np.zeros((len(r), self.n))
        duals = [None] * len(r)
        for j, i in enumerate(r):
            w = warm[i]
            if w is not None:
                x = np.asarray(w.accelerations if isinstance(w, Plan) else w, dtype=float)
                a[j] = x if x.shape == (self.n,) else (np.resize(x, self.n) if x.size else 0.0)
                y = w.duals if isinstance(w, Plan) else None
                duals[j] = y if y is not None and y.shape == (2 * self.n,) else None
        return self.project(a, r), duals

    def project(self, a: np.ndarray, r: np.ndarray) -> np.ndarray:
        """``a`` (len(r), N) made feasible row by row where it is not (problem.project_accelerations)."""
        a = np.clip(np.where(np.isfinite(a), a, 0.0), self.a_lo[r, None], self.a_hi[r, None])
        cs = a.cumsum(axis=1)
        bad = (cs.min(axis=1) < self.sum_lo[r]) | (cs.max(axis=1) > self.sum_hi[r])
        for j in np.nonzero(bad)[0]:
            i = r[j]
            a[j] = project_accelerations(a[j], self.v0[i], self.v_cap[i], self.limits[i])
        return a

    def keep_behind(self, a: np.ndarray, r: np.ndarray) -> np.ndarray:
        """PlayerObjective.keep_behind of rows ``r``: a start that overlaps its leader is moved
        behind it."""
        _, s = self._vs(a, r)
        over = self.lead[r] & (s > self.bound[r]).any(axis=1)
        for j in np.nonzero(over)[0]:
            i = r[j]
            a[j] = stay_behind(a[j], self.s0[i], self.v0[i], self.bound[i], self.dt, self.a_lo[i])
        return a

    # ------------------------------------------------------------------ solve
    def solve(self, warm: Sequence[Plan | None]) -> list[tuple]:
        """Per row: (plan, true cost [-], [(residual [m/s^2], converged)], QPs, failure or None)."""
        sv = self.gs.solver
        r = np.arange(self.m)
        a, duals = self.start(warm, r)
        st = _Rows(a, np.zeros(self.m), np.zeros(self.m), duals, [None] * self.m, np.zeros(self.m, int),
                   [None] * self.m)
        cold = np.array([w is None for w in warm], bool)
        if cold.any():  # the decoupled start of Eq. 33: one SQP step from zero acceleration
            self._sqp_step(st, np.nonzero(cold)[0], np.full(self.m, sv.trust_region))
            st.duals = [st.y[i] if cold[i] else st.duals[i] for i in range(self.m)]
        residuals = [[] for _ in range(self.m)]
        active = np.array([f is None for f in st.failure], bool)
        delta = np.full(self.m, sv.trust_region)
        for _ in range(sv.nash_max_iter):
            rows = np.nonzero(active)[0]
            if not rows.size:
                break
            old = st.a[rows].copy()
            c0 = self._sqp_step(st, rows, delta)
            delta[rows] = st.delta[rows]
            st.duals = list(st.y)
            res = np.abs(st.a[rows] - old).max(axis=1)
            gain = (c0 - st.cost[rows]) / np.maximum(np.abs(c0), 1e-9)
            done = (res < sv.nash_tol) | ((res < sv.nash_cost_guard) & (gain < sv.nash_cost_rtol))
            for j, i in enumerate(rows):
                if st.failure[i] is None:
                    residuals[i].append((float(res[j]), bool(done[j])))
                active[i] = st.failure[i] is None and not done[j]
        return self._results(st, residuals)

    def _results(self, st: _Rows, residuals) -> list[tuple]:
        hm = self.hm
        full = st.a @ hm.M.T  # (m, 2N + 2)
        n1 = self.n + 1
        out = []
        for i in range(self.m):
            if st.failure[i] is None and not (math.isfinite(st.cost[i]) and np.isfinite(full[i]).all()):
                st.failure[i] = "non-finite plan or cost"
            if st.failure[i] is not None:
                out.append((None, math.nan, [], int(st.qps[i]), st.failure[i]))
                continue
            x = full[i] + state_offset(float(self.s0[i]), float(self.v0[i]), hm)
            y = st.y[i] if st.y[i] is not None else st.duals[i]
            plan = Plan(st.a[i].copy(), x[:n1], x[n1:], self.dt, y)
            out.append((plan, float(st.cost[i]), residuals[i], int(st.qps[i]), None))
        return out

    def _sqp_step(self, st: _Rows, rows: np.ndarray, delta0: np.ndarray) -> np.ndarray:
        """One SQP step (sqp.sqp_best_response with one iteration) of ``rows`` from st.a; updates
        st in place and returns the true costs at the start (after keep_behind)."""
        sv = self.gs.solver
        a = self.keep_behind(st.a[rows], rows)
        c = self.cost(a, rows)
        g, H = self.model(a, rows)
        exact = ~self.lead[rows]  # no coupling term: the model is the cost
        st.a[rows], st.cost[rows] = a, c
        st.delta[rows] = np.where(exact, sv.trust_region_max, delta0[rows])
        bad = ~np.isfinite(c)
        for j in np.nonzero(bad)[0]:
            st.failure[rows[j]] = "non-finite cost at the start"
        self._region(st, rows[~bad], g[~bad], H[~bad], exact[~bad])
        return c

    def _region(self, st: _Rows, rows: np.ndarray, g: np.ndarray, H: np.ndarray, exact: np.ndarray) -> None:
        """sqp._trust_region_step for ``rows``: solve the model QPs, shrinking each row's region
        until a step lowers its true cost enough, its model is stationary, or the region falls
        below ``trust_region_min``."""
        pending = np.arange(len(rows))  # positions into rows / g / H
        first = True
        while pending.size:
            rp = rows[pending]
            x, pred, step, ok = self._qps(st, rp, g[pending], H[pending], first)
            first = False
            keep = ok
            pending, rp, x, pred, step = pending[keep], rp[keep], x[keep], pred[keep], step[keep]
            if not pending.size:
                break
            a, c = st.a[rp], st.cost[rp]
            still = self._accept(st, rp, a, c, x, pred, step, exact[pending])
            pending = pending[still]

    def _qps(self, st: _Rows, rp: np.ndarray, g: np.ndarray, H: np.ndarray, first: bool):
        """The model QP of each row ``rp`` in its trust region (sqp._solve_qp): projected
        solutions (len, N), predicted decreases, step sizes, and which rows solved (a row whose QP
        failed is marked failed)."""
        n = self.n
        a = st.a[rp]
        lo = np.maximum(a - st.delta[rp, None], self.a_lo[rp, None])
        hi = np.minimum(a + st.delta[rp, None], self.a_hi[rp, None])
        ws = workspace(n, self.gs, ("nash", 0))  # the slot solo_response uses
        sp_lo, sp_hi = ws.speed_rows(self.v0[rp], self.v_cap[rp], self.dt)
        l, u = np.concatenate((lo, sp_lo), axis=1), np.concatenate((hi, sp_hi), axis=1)
        found, x, y = ws.exact_many(H, g, a, l, u)  # most QPs: exact answers, one compiled call
        ok = np.ones(len(rp), bool)
        st.qps[rp] += 1
        for j in np.flatnonzero(~found):
            i = rp[j]
            # never another vehicle's installed P (hessian_reuse_tol is a max-norm test that the
            # small comfort terms pass whatever their weight): a capped solve takes the QP's answer
            sol = ws.solve(H[j], g[j], a[j], l[j], u[j], y0=st.duals[i] if first else None, reuse=False, exact=False)
            if not sol.ok:
                st.failure[i], ok[j], x[j] = f"OSQP: {sol.status}", False, a[j]
                continue
            x[j], y[j] = sol.x, sol.y
        for j in np.flatnonzero(ok):
            st.y[rp[j]] = y[j]
        x = np.minimum(np.maximum(x, self.a_lo[rp, None]), self.a_hi[rp, None])
        cs = x.cumsum(axis=1)
        bad = ok & ((cs.min(axis=1) < self.sum_lo[rp]) | (cs.max(axis=1) > self.sum_hi[rp]))
        for j in np.nonzero(bad)[0]:
            i = rp[j]
            x[j] = project_accelerations(x[j], self.v0[i], self.v_cap[i], self.limits[i])
        d = x - a  # every QP used its own H (reuse=False)
        pred = np.where(ok, -(np.einsum("mi,mi->m", g, d) + 0.5 * np.einsum("mi,mij,mj->m", d, H, d)), 0.0)
        step = np.abs(x - a).max(axis=1)
        return x, pred, step, ok

    def _accept(self, st: _Rows, rp, a, c, x, pred, step, exact) -> np.ndarray:
        """Stationarity test, line search and radius update of sqp._trust_region_step for rows
        ``rp``; returns the mask of rows whose region shrank and must be solved again."""
        sv = self.gs.solver
        d = x - a
        stationary = (step < sv.br_step_tol) | (pred <= sv.br_rel_decrease_tol * np.maximum(np.abs(c), 1e-9))
        c_x = self.cost(x, rp)
        if not np.isfinite(c_x[~stationary]).all():
            for j in np.nonzero(~stationary & ~np.isfinite(c_x))[0]:
                st.failure[rp[j]] = "non-finite cost"
        # stationary for the model: keep the tiny step only if it does not raise the cost
        tiny = stationary & (step > 0.0) & (c_x <= c)
        st.a[rp[tiny]], st.cost[rp[tiny]] = x[tiny], c_x[tiny]
        alpha, c_new = self._line_search(rp, a, c, d, pred, c_x, exact)
        alive = np.array([st.failure[i] is None for i in rp], bool)
        moved = ~stationary & (alpha > 0.0) & alive
        for j in np.nonzero(moved)[0]:
            i = rp[j]
            st.delta[i] = new_radius(sv, float(st.delta[i]), float(alpha[j]), float(step[j]),
                                      float((c[j] - c_new[j]) / pred[j]))
            st.a[i] = x[j] if alpha[j] == 1.0 else a[j] + alpha[j] * d[j]
            st.cost[i] = c_new[j]
        shrink = ~stationary & (alpha <= 0.0) & ~exact & alive
        st.delta[rp[shrink]] = 0.25 * np.minimum(st.delta[rp[shrink]], step[shrink])
        return shrink & (st.delta[rp] >= sv.trust_region_min)

    def _line_search(self, rp, a, c, d, pred, c_x, exact) -> tuple[np.ndarray, np.ndarray]:
        """sqp._line_search per row: (alpha, true cost at a + alpha d); alpha 0 where no step of
        1, 1/2, 1/4, ... (``line_search_steps`` halvings, none for an exact model) meets Armijo's
        condition."""
        sv = self.gs.solver
        alpha = np.where(c_x <= c - sv.armijo * pred, 1.0, 0.0)
        c_new = c_x.copy()
        todo = np.nonzero((alpha == 0.0) & ~exact & np.isfinite(c_x))[0]
        if sv.line_search_steps > 0 and todo.size:
            alphas = 0.5 ** np.arange(1, sv.line_search_steps + 1)
            trial_a = a[todo, None, :] + alphas[None, :, None] * d[todo, None, :]
            k = len(alphas)
            trial = self.cost(trial_a.reshape(-1, self.n), np.repeat(rp[todo], k)).reshape(len(todo), k)
            good = trial <= (c[todo, None] - sv.armijo * alphas[None, :] * pred[todo, None])
            for j, row in zip(todo, range(len(todo))):
                hit = np.nonzero(good[row])[0]
                if hit.size:
                    alpha[j], c_new[j] = alphas[hit[0]], trial[row, hit[0]]
        return alpha, c_new

