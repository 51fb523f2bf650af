"""Settings of the game layer (paper Section IV): the game problem and the solver, each one
typed frozen object with documented defaults.

The cost weights of the paper (Eqs. 13-24) stay in
:class:`~intersection_cosim.models.settings.ModelSettings`. :class:`ProblemSettings` holds what
defines the game the paper leaves open (the horizon, the input limits, the comfort regulariser,
the safe fallback plan) and is set from a scenario's ``[controller.game]`` table;
:class:`SolverSettings` holds the numerical knobs of the SQP / OSQP solvers
(``[controller.solver]``). :class:`GameSettings` is the pair, what every solver of this layer takes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from intersection_cosim.settings import non_negative, positive

SCHEMES = ("gauss-seidel", "jacobi")
COUPLINGS = ("pairwise", "cluster")


@dataclass(frozen=True)
class ProblemSettings:
    """The open-loop game every player solves (``[controller.game]``)."""

    horizon: float = 3.0  # [s] planning horizon T of the open-loop game (Eq. 10: t in [0, T])
    dt: float = 0.1  # [s] step of the acceleration sequence; N = horizon / dt decisions per player
    a_min: float = -4.0  # [m/s^2] hardest braking a player may plan (U^i of Eq. 11)
    a_max: float = 2.5  # [m/s^2] strongest acceleration a player may plan (U^i of Eq. 11)
    comfort_brake: float = 2.0  # [m/s^2] deceleration of the safe fallback plan (brake to a stop)
    # Comfort regulariser, added to every player's cost (not in the paper): each best response is
    # strictly convex in the accelerations even when kappa = 0 and no interaction is active (then
    # the paper's running cost is constant and every plan is optimal). Cost per step
    # dt * (w_accel a^2 + w_jerk ((a_k - a_{k-1}) / dt)^2), in the units of J_e.
    w_accel: float = 0.1  # [s^4/m^2] weight of the squared acceleration at kappa = 0.5
    # [s^4/m^2] fall of that weight per unit of kappa: a player's weight is
    # max(min(w_accel_floor, w_accel), w_accel + w_accel_kappa (0.5 - kappa)), so an aggressive
    # driver accelerates and brakes harder and a cautious one keeps its plan smoother (0: the same
    # for all). 0.25: kappa 0.2 weighs 0.175, 0.8 0.025 (decision record 024)
    w_accel_kappa: float = 0.25
    # [s^4/m^2] least comfort weight of any player, where w_accel_kappa lowers it (it never
    # raises a weight above w_accel): its best response stays strictly convex (a kappa-0.9
    # player would have none; behind a leader its cost was then flat to 1e-5 over plans
    # 0.02 m/s^2 apart, so the answer depended on the solver's path)
    w_accel_floor: float = 0.01
    w_jerk: float = 0.0005  # [s^6/m^2] weight of the squared jerk inside the plan
    coupling: str = "pairwise"  # [-] who plays with whom: "pairwise" (the paper's: every triggered pair
    #                              plays its own two-player game) or "cluster" (each connected group of
    #                              three or more triggered vehicles plays one N-player game, games/coupled.py)

    @property
    def steps(self) -> int:
        """[-] N = horizon / dt, decisions per player."""
        return int(round(self.horizon / self.dt))

    def check(self) -> list[tuple[str, str]]:
        problems = positive(self, "horizon", "dt", "a_max", "comfort_brake")
        problems += non_negative(self, "w_accel", "w_accel_kappa", "w_accel_floor", "w_jerk")
        if not self.a_min < 0:
            problems.append(("a_min", "must be < 0"))
        if self.horizon > 0 and self.dt > 0 and abs(self.horizon / self.dt - self.steps) > 1e-9:
            problems.append(("horizon", "must be a whole number of steps dt"))
        if not self.comfort_brake <= -self.a_min:
            problems.append(("comfort_brake", "must be <= -a_min"))
        if self.coupling not in COUPLINGS:
            problems.append(("coupling", f"must be one of {', '.join(COUPLINGS)}"))
        return problems


@dataclass(frozen=True)
class SolverSettings:
    """Equilibrium iterations, best responses and OSQP (``[controller.solver]``)."""

    # --- equilibrium iteration (Section IV-C, IV-D) ---
    scheme: str = "gauss-seidel"  # [-] "gauss-seidel" or "jacobi" best-response iteration
    nash_max_iter: int = 30  # [-] iteration cap of the Nash best-response iteration
    sqp_steps_per_iteration: int = 1  # [-] SQP steps of each best response inside one iteration
    # [m/s^2] the Nash iteration has converged when no plan moved more than this in one iteration
    nash_tol: float = 1e-2
    # [-] the Nash iteration has also converged when no best response lowered its player's true
    # cost by more than this (relative) and no plan moved more than nash_cost_guard: every player is then within a second-order small
    # gain of its best response (a flat optimum may still shift a plan a little)
    nash_cost_rtol: float = 1e-3
    nash_cost_guard: float = 0.3  # [m/s^2] largest plan move the cost test of nash_cost_rtol accepts
    cold_start_orders: bool = False  # [-] cold Nash: also start from each passing order (3x the work)
    stackelberg_max_iter: int = 20  # [-] cap on leader iterations
    stackelberg_tol: float = 1e-2  # [m/s^2] converged when the leader's step is smaller than this
    stackelberg_gain_rtol: float = 1e-3  # [-] ... or its model gain is below this fraction
    stackelberg_attempts: int = 1  # [-] leader QPs per iteration: after a rejected step (all its
    #                                halves tried) the trust region shrinks and the QP is re-solved
    # [-] Stackelberg: a follower not settled when the leader's iteration stops is polished to a full
    # best response (up to br_max_sqp SQP steps); False keeps its last answer, as at a deadline,
    # and the solve counts as not converged: the real-time iteration of a game in progress
    # (PolicySettings.game_max_iter) goes on from it at the next step
    polish_follower: bool = True
    active_set_max_updates: int = 4  # [-] follower active-set updates per leader step
    active_tol: float = 1e-3  # [m/s^2] a row within this of its bound starts in the active set

    # --- best response: sequential QP with trust region and line search ---
    br_max_sqp: int = 20  # [-] SQP iterations of a stand-alone best response
    br_step_tol: float = 1e-3  # [m/s^2] stop when the accepted step is smaller than this
    br_rel_decrease_tol: float = 1e-7  # [-] stop when the model decrease < this * |cost|
    trust_region: float = 1.5  # [m/s^2] initial trust-region radius on |a - a_iterate|
    trust_region_min: float = 1e-3  # [m/s^2] give up improving below this radius
    trust_region_max: float = 6.5  # [m/s^2] largest radius (a_max - a_min covers the whole box)
    line_search_steps: int = 2  # [-] step halvings tried before the trust region shrinks
    armijo: float = 1e-4  # [-] sufficient-decrease fraction of the model decrease
    gap_floor: float = 0.1  # [m] gap floor in the derivative of J_log (Eq. 16) near contact
    hessian_refresh: float = 0.2  # [m/s^2] within one solve, reuse a player's model Hessian until
    #                               its plan or a partner's moved more than this

    # --- OSQP (one workspace per problem shape, updated and warm-started) ---
    osqp_eps_abs: float = 1e-4  # [-] absolute tolerance on the normalised QP
    osqp_eps_rel: float = 1e-4  # [-] relative tolerance
    osqp_max_iter: int = 4000  # [-] ADMM iteration cap; hitting it is a solver failure
    osqp_check_termination: int = 5  # [-] ADMM iterations between termination checks
    hessian_reuse_tol: float = 0.05  # [-] keep OSQP's installed P (no refactorisation) if the new
    #                                  Hessian differs from it by less than this (relative)
    # [-] passes of the exact active-set solve over the input-box rows tried before OSQP when
    # the QP's unconstrained minimiser breaks a row (games/qp.py, "Box solutions"; 0: OSQP)
    qp_box_iter: int = 6

    def check(self) -> list[tuple[str, str]]:
        problems = positive(self, "nash_tol", "nash_max_iter", "sqp_steps_per_iteration", "stackelberg_tol",
                            "stackelberg_max_iter", "stackelberg_attempts", "br_max_sqp", "br_step_tol",
                            "trust_region", "trust_region_min", "trust_region_max", "gap_floor", "osqp_eps_abs",
                            "osqp_max_iter", "osqp_check_termination")
        problems += non_negative(self, "active_set_max_updates", "active_tol", "line_search_steps", "armijo",
                                 "br_rel_decrease_tol", "osqp_eps_rel", "hessian_reuse_tol", "hessian_refresh",
                                 "qp_box_iter", "nash_cost_rtol", "nash_cost_guard", "stackelberg_gain_rtol")
        if self.scheme not in SCHEMES:
            problems.append(("scheme", f"must be one of {', '.join(SCHEMES)}"))
        if not self.trust_region_min <= self.trust_region <= self.trust_region_max:
            problems.append(("trust_region", "must lie in [trust_region_min, trust_region_max]"))
        return problems


@dataclass(frozen=True)
class GameSettings:
    """The game problem and its solver: what the solvers of this layer take."""

    problem: ProblemSettings = field(default_factory=ProblemSettings)
    solver: SolverSettings = field(default_factory=SolverSettings)
