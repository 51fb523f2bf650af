"""Model parameters of the paper's decision layer, one typed object with documented defaults.

Every field can be set from a scenario file's ``[model]`` table; an unknown key is an error.
The paper gives no numbers for most of these; the defaults are our calibration, chosen so that
the paper's qualitative results hold (docs/decisions/ has the reasons and measurements).
"""

from __future__ import annotations

from dataclasses import dataclass

from intersection_cosim.settings import non_negative, positive


@dataclass(frozen=True)
class ModelSettings:
    # --- vehicle (the paper gives no dimensions) ---
    vehicle_length: float = 4.5  # [m] bumper to bumper
    vehicle_width: float = 1.8  # [m] W in Eq. 8 (d = W / 4)
    l_f: float = 1.35  # [m] centre of gravity to front axle (Eqs. 2-3)
    l_r: float = 1.35  # [m] centre of gravity to rear axle (Eqs. 2-3)

    # --- potential field, Eqs. 5-8 ---
    a0: float = 1.0  # [-] field amplitude at kappa = 0; a = a0 * exp(kappa) (Eq. 7)
    b: float = 0.1  # [-] widening slope of the field with arc length when delta_f = 0 (Eq. 8)
    c: float = 0.5  # [1/rad] gain of |delta_f| in the widening (Eq. 8)
    # [s] preview time of the prediction and of the field (Eq. 7): long enough that the trigger
    # sees the paper's conflict points (20-27 m ahead) from the first second
    t_p: float = 4.0
    # [s] fall of the preview time per unit of kappa: vehicle i previews
    # t_p^i = max(t_p_min, t_p + t_p_kappa (0.5 - kappa^i)) (Eq. 7 gives each AV its own t_p^i), so
    # a cautious driver sees a conflict, and plays its game, earlier than an aggressive one
    # (0: every vehicle t_p). 4: kappa 0.2 previews 5.2 s, 0.8 2.8 s, so Case 1 B's yielders play
    # from the first step instead of being braked by the safety filter (decision record 031)
    t_p_kappa: float = 4.0
    t_p_min: float = 1.0  # [s] the shortest preview time t_p^i
    # The prediction is along the paths (models/prediction.py), in closed form: no sampled rollout
    # or polynomial fit reads these two. They stay so scenario files that set them still load and
    # summary.json keeps its fields.
    prediction_dt: float = 0.1  # [s] sample step of a sampled prediction over t_p (unused)
    prediction_degree: int = 3  # [-] degree of a polynomial fit of a free prediction (Sec. III-C; unused)
    # [rad] below this |delta_f| the straight-line field form is used. The curved form is exact in
    # double precision far below this; the switch only avoids R = l / tan(0). At 1e-6 rad the two
    # forms agree to 1e-3 relative over a 42 m preview (14 m/s * 3 s); at 1e-3 they differ by 10 %.
    straight_steer: float = 1e-6
    # [a0 m^2] safe value of Gamma_cp; the ETM triggers a game above it (Eqs. 9, 39). Calibration in
    # models/risk.py: with kappa = 0.5 and t_p = 4 s it fires for arrival-time gaps below ~3 s at
    # 5 m/s.
    gamma_sf: float = 40.0

    # --- running cost, Eqs. 13-24 ---
    eps: float = 0.25  # [s^2] epsilon in J_log and J_lat (Eqs. 15, 19)
    k_log: float = 1.0  # [-] weight of longitudinal safety J_log (Eq. 14)
    # [-] weight of lateral safety J_lat (Eq. 14): strong enough against J_e at TTC_lat ~2 s for
    # the games to trade speed for margin by kappa (calibrated with t_p)
    k_lat: float = 5.0
    # [-] how strongly a partner's aggressiveness scales the risk it poses: each J_lat term of a
    # player is weighted by exp(k_lat_partner (kappa_q - 0.5)), kappa_q the partner's (the
    # potential field of a more aggressive vehicle is stronger, a^q = a_0 exp(kappa^q), Eq. 7);
    # 0: every partner alike (Eq. 19 as written), 1: Eq. 7's factor (decision records 022-024)
    k_lat_partner: float = 3.5
    # [-] how strongly a player's own aggressiveness scales the risk it takes: each of its J_lat
    # terms (with an AV or a human crosser) is also weighted by exp(-k_lat_own (kappa_p - 0.5)),
    # kappa_p its own; 1 is Eq. 7's factor of its own field, so a term weighs the partner's field
    # against its own. 0: Eq. 13's (1 - kappa) alone. The product of the two factors is floored
    # at 1 (games/objective.py lateral_risk_weight): a player never cares less than Eq. 19 does.
    # With it a cautious follower yields earlier and more (decision record 023)
    k_lat_own: float = 1.0
    k_lk: float = 1.0  # [-] weight of lane-keeping safety J_lk (Eq. 14)
    k_y_lk: float = 0.008  # [1/m^2] weight of the lateral offset in J_lk (Eq. 23; calibrated on Case 2)
    k_phi_lk: float = 0.5  # [1/rad^2] weight of the heading error in J_lk (Eq. 23)
    k_e: float = 0.04  # [s^2/m^2] weight of the speed error in J_e (Eq. 24)
    v_max: float = 10.0  # [m/s] maximum (desired) speed in J_e (Eq. 24)
    # [-] keep to the net's lane speed limits (a turn's internal lanes, a slow road): a controlled
    # vehicle's v_max is the lowest limit in force where it is (MovementPath.speed_limit_ahead,
    # slowing at lane_speed_decel before the lane), and the lane_speed_limit rule of the safety
    # filter holds it, as SUMO's drivers keep them. Off: every vehicle plans up to v_max
    # everywhere (the paper's model, which has no speed limits)
    lane_speed_limits: bool = True
    lane_speed_decel: float = 2.0  # [m/s^2] ... the deceleration a limit ahead is planned with
    tcp_speed_floor: float = 0.1  # [m/s] speed floor in TCP = distance / speed (Eqs. 21-22)
    conflict_clearance: float = 4.5  # [m] past the conflict point by this, a vehicle has passed it

    # --- roles ---
    # [m] the conflict zone is |x|, |y| <= this (Section II). Unused: the simulator layer gives each
    # vehicle its role from its SUMO lane (sim/sumo.py: junction-internal = passing, approach =
    # ready, exit = outside); kept so scenario files that set it still load and summary.json keeps it.
    conflict_zone_half: float = 12.0

    def check(self) -> list[tuple[str, str]]:
        problems = positive(self, "vehicle_length", "vehicle_width", "l_f", "l_r", "a0", "t_p",
                            "eps", "v_max", "tcp_speed_floor", "conflict_zone_half", "t_p_min",
                            "straight_steer", "prediction_dt", "lane_speed_decel")
        if self.prediction_degree < 1:
            problems.append(("prediction_degree", "must be >= 1"))
        problems += non_negative(self, "t_p_kappa", "b", "c", "gamma_sf", "k_log", "k_lat", "k_lat_partner", "k_lat_own", "k_lk", "k_y_lk",
                                 "k_phi_lk", "k_e", "conflict_clearance")
        return problems

    @property
    def wheelbase(self) -> float:
        """[m] l = l_f + l_r (Eqs. 3, 5-6)."""
        return self.l_f + self.l_r
