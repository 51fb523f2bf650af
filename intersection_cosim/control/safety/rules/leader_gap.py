"""leader_gap: A follower never drives faster than Krauss' safe speed behind its leader: reacting
after one control period and braking at its own braking, it stops at least ``margin`` behind the
leader however the leader brakes up to the braking counted on for it (an emergency stop included).

Trigger: a commanded vehicle with a tracked leader on the exit lane it takes (the same approach
lane, or a confluence after the merge).

Action: caps its acceleration at the Krauss speed; where that needs more than its own braking, the
follower may brake up to its vType's emergencyDecel, no harder than the Krauss speed needs, and
the vehicles behind it then count on that braking. At a merge a leader whose rear is not yet
``margin`` ahead along the follower's path may still be turning in, its body off that path: its
speed earns no credit and the follower stops until it is ahead.

Setting: ``[controller.safety] margin``; the braking limits ``[controller.game] a_min`` and each
vType's ``decel`` and ``emergencyDecel``.

Test: tests/control/test_safety_filter.py::test_a_follower_is_capped_at_krauss_safe_speed
"""

from __future__ import annotations

import math

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.onboard import krauss_safe_speed
from intersection_cosim.control.safety.rules.base import SAFETY, Rule
from intersection_cosim.control.safety.step import FilterStep

NAME = "leader_gap"


def leader_caps(ctx: StepContext, brakes: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """[m/s^2] per follower the Krauss cap behind its leader (the leader braking as ``brakes``
    [m/s^2] count on); and per follower whose cap needs more than its braking, the braking
    [m/s^2] (< 0) it may use instead (its emergencyDecel at most)."""
    world, j = ctx.world, ctx.junction
    rows, a_min, period = ctx.relations.rows, j.problem.a_min, j.period
    cap: dict[str, float] = {}
    harder: dict[str, float] = {}
    for r, lead in ctx.relations.leaders.items():
        k = int(rows.vehicle[r])
        vid = world.ids[k]
        if not ctx.may_cap(vid) or not ctx.chosen[r]:
            continue
        length = world.length_of(lead.vehicle, j.model.vehicle_length)  # [m] the leader's body
        gap = lead.gap - length - ctx.settings.margin - j.gap_slack  # [m] bumper to bumper, less margin
        lead_brake = brakes.get(world.ids[lead.vehicle], a_min)  # [m/s^2]
        v, v_lead = float(world.v[k]), float(world.v[lead.vehicle])  # [m/s]
        if lead.merge and gap < 0.0:
            cap[vid] = min(cap.get(vid, math.inf), -v / period)
            continue
        limit = (krauss_safe_speed(gap, v_lead, -ctx.brake(k), period, -lead_brake) - v) / period
        cap[vid] = min(cap.get(vid, math.inf), limit)
        own = brakes.get(vid, a_min)  # [m/s^2]
        if limit < own and (em := world.emergency_brake(k, own)) < own:
            need = (krauss_safe_speed(gap, v_lead, -em, period, -lead_brake) - v) / period
            harder[vid] = min(harder.get(vid, own), max(em, need))
    return cap, {vid: b for vid, b in harder.items() if b < brakes.get(vid, a_min)}


def run(ctx: StepContext, step: FilterStep) -> None:
    cap, harder = leader_caps(ctx, step.brakes)
    if harder:  # followers that must brake harder than their own braking: theirs count on it
        step.brakes.update(harder)
        cap, harder = leader_caps(ctx, step.brakes)
        step.brakes.update(harder)
    for vid, a in cap.items():
        step.lower(vid, a, NAME)


RULE = Rule(NAME, SAFETY, run)
