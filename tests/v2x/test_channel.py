"""The V2X channel on hand-made Worlds: latency, loss, dead reckoning, commands, plausibility."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from intersection_cosim.control.base import Decisions, World
from intersection_cosim.v2x import AttackSettings, Channel, V2XSettings
from intersection_cosim.v2x.reckoning import dead_reckon, reach

PID = "south_middle_straight_middle"
PERIOD = 0.1  # [s] control period = message period


def truth(movements, t: float, s: float, v: float, a: float = 0.0, vid: str = "A") -> World:
    """SUMO's World with one vehicle on PID at arc length s [m], speed v [m/s], accel a [m/s^2]."""
    path = movements.paths[PID]
    x, y = path.point_at(s)
    return World(time=t, ids=[vid], path_ids=[PID], s=np.array([s]), v=np.array([v]), a=np.array([a]),
                 x=np.array([x]), y=np.array([y]), heading=np.array([path.heading_at(s)]),
                 kappa=np.array([0.5]), role=["ready"], lanes=[path.lanes[0]],
                 exit_choices={vid: (path.exit_lane,)}, desired_speed=np.array([np.nan]))


def drive(channel, movements, times, s0=20.0, v=10.0):
    """Send a vehicle at constant speed ``v`` from ``s0`` at each time; return the Worlds seen."""
    seen = []
    for t in times:
        w = truth(movements, t, s0 + v * t, v)
        channel.uplink(w)
        seen.append(channel.observe(w))
    return seen


def test_dead_reckoning_numbers():
    assert dead_reckon(10.0, 8.0, 1.0, 2.0) == pytest.approx((10.0 + 16.0 + 2.0, 10.0))
    assert dead_reckon(10.0, 4.0, -2.0, 5.0) == pytest.approx((14.0, 0.0))  # stops after 2 s at 10 + 4
    assert dead_reckon(10.0, 4.0, -2.0, 1.0) == pytest.approx((13.0, 2.0))
    r = reach(0.0, 10.0, 1.0, max_accel=3.0, max_decel=4.5, max_speed=11.0)
    # up: 1/3 s at 3 m/s^2 to 11 m/s, then 2/3 s at 11 m/s
    assert r.s_hi == pytest.approx(10 / 3 + 1.5 / 9 + 11 * 2 / 3) and r.v_hi == 11.0
    assert (r.s_lo, r.v_lo) == pytest.approx((10.0 - 2.25, 5.5))


@pytest.mark.parametrize("latency,messages", [(0.0, 0), (0.1, 1), (0.2, 2), (0.3, 3)])
def test_latency_shifts_by_whole_messages(movements, latency, messages):
    ch = Channel(V2XSettings(latency=latency), movements, PERIOD, seed=1)
    times = [round(k * PERIOD, 6) for k in range(10)]
    seen = drive(ch, movements, times)
    assert [len(w) for w in seen[:messages]] == [0] * messages  # nothing has arrived yet
    assert len(seen[messages]) == 1
    assert ch.tracks["A"].accepted.stamp == pytest.approx(times[-1] - messages * PERIOD)
    # constant speed: dead reckoning puts it exactly where it is
    assert seen[-1].s[0] == pytest.approx(20.0 + 10.0 * times[-1])


def test_dead_reckoning_along_the_path_with_consistent_xy_and_heading(movements):
    ch = Channel(V2XSettings(latency=0.5), movements, PERIOD, seed=1)
    ch.uplink(truth(movements, 0.0, 60.0, 8.0, a=-2.0))
    w = ch.observe(truth(movements, 0.5, 63.75, 7.0))
    assert w.s[0] == pytest.approx(60.0 + 8.0 * 0.5 - 0.25)  # s + v age + a age^2 / 2
    assert w.v[0] == pytest.approx(7.0)
    path = movements.paths[PID]
    assert (w.x[0], w.y[0]) == pytest.approx(tuple(path.point_at(w.s[0])))
    assert w.heading[0] == pytest.approx(path.heading_at(w.s[0]))
    late = ch.observe(truth(movements, 10.0, 76.0, 0.0))  # stops after 4 s: 60 + 8^2 / 4
    assert (late.s[0], late.v[0]) == pytest.approx((76.0, 0.0))


@pytest.mark.parametrize("loss", [0.1, 0.3])
def test_loss_rate_by_seed(movements, loss):
    def counts(seed):
        ch = Channel(V2XSettings(loss=loss, plausibility=False), movements, PERIOD, seed=seed)
        drive(ch, movements, [round(k * PERIOD, 6) for k in range(4000)], v=0.0)
        return ch.counts["messages_lost"], ch.counts["messages_sent"]

    lost, sent = counts(7)
    assert sent == 4000
    assert abs(lost / sent - loss) < 3 * np.sqrt(loss * (1 - loss) / sent)
    assert counts(7) == (lost, sent)  # same seed, same losses
    assert counts(8)[0] != lost


def test_lost_message_leaves_the_last_state_extrapolated(movements):
    ch = Channel(V2XSettings(loss=1e-12), movements, PERIOD, seed=1)
    ch.uplink(truth(movements, 0.0, 20.0, 10.0))
    ch.observe(truth(movements, 0.0, 20.0, 10.0))
    w = ch.observe(truth(movements, 0.3, 23.0, 10.0))  # no message sent since: predicted from t = 0
    assert ch.tracks["A"].accepted.stamp == 0.0 and w.s[0] == pytest.approx(23.0)


def test_commands_delayed_by_the_latency(movements):
    ch = Channel(V2XSettings(latency=0.2), movements, PERIOD, seed=1)
    ch.send(Decisions(accel={"A": -1.5}, exit_lane={"A": "inner"}), 1.0)
    assert ch.deliver(1.0) is None and ch.deliver(1.15) is None
    got = ch.deliver(1.2)
    assert got.accel == {"A": -1.5} and got.exit_lane == {"A": "inner"}
    assert ch.deliver(1.25) is None  # delivered once


def test_lost_command_keeps_the_last(movements):
    ch = Channel(V2XSettings(loss=0.5), movements, PERIOD, seed=3)
    delivered = []
    for k in range(200):
        ch.send(Decisions(accel={"A": float(k)}), k * PERIOD)
        got = ch.deliver(k * PERIOD)
        delivered.append(got.accel["A"] if got is not None else None)
    lost = [k for k, d in enumerate(delivered) if d is None]
    assert ch.counts["commands_lost"] == len(lost) and 60 < len(lost) < 140
    assert all(delivered[k] == k for k in range(200) if k not in lost)  # nothing else sent: no other command


def test_plausibility_rejects_a_5_m_jump_and_accepts_a_physical_message(movements):
    ch = Channel(V2XSettings(), movements, PERIOD, seed=1)
    last = truth(movements, 0.0, 20.0, 10.0)
    ch.uplink(last)
    ch.observe(last)
    accepted = ch.tracks["A"].accepted
    ok = dataclasses.replace(accepted, stamp=0.1, s=21.0 + 0.5 * 2.5 * 0.01, v=10.25)  # 2.5 m/s^2 for 0.1 s
    assert ch.plausible(accepted, ok)
    jump = dataclasses.replace(accepted, stamp=0.1, s=21.0 + 5.0)
    assert not ch.plausible(accepted, jump)
    too_fast = dataclasses.replace(accepted, stamp=0.1, s=21.0, v=12.0)  # +2 m/s in 0.1 s
    assert not ch.plausible(accepted, too_fast)
    old = dataclasses.replace(accepted, stamp=0.0)  # not newer
    assert not ch.plausible(accepted, old)


def test_a_braking_the_controller_commanded_is_plausible_beyond_max_decel(movements):
    """An emergency stop at 7 m/s^2 (control/safety/pedestrians.py) seen over a gap in the messages lies
    outside the 4.5 m/s^2 bound: it passes once the controller itself has sent that braking, and
    for that vehicle only."""
    ch = Channel(V2XSettings(), movements, PERIOD, seed=1)
    last = truth(movements, 0.0, 20.0, 10.0)
    ch.uplink(last)
    ch.observe(last)
    accepted = ch.tracks["A"].accepted
    # 7 m/s^2 for 0.5 s (four messages lost): 3.5 m/s slower, beyond 4.5 m/s^2 and the 0.5 m/s slack
    hard = dataclasses.replace(accepted, stamp=0.5, s=20.0 + 5.0 - 0.5 * 7.0 * 0.25, v=10.0 - 3.5)
    assert not ch.plausible(accepted, hard)
    ch.send(Decisions(accel={"B": -7.0}), 0.0)  # another vehicle's command
    assert not ch.plausible(accepted, hard)
    ch.send(Decisions(accel={"A": -7.0}), 0.0)
    assert ch.plausible(accepted, hard)
    assert ch.decel_bound("A", 0.0, 0.5) == pytest.approx(7.0) and ch.decel_bound("A", 5.0, 5.1) == pytest.approx(4.5)


def test_a_lost_release_is_sent_again_until_it_arrives(movements):
    """The controller lets a vehicle go once; with that command lost it kept its last
    acceleration on the exit lane for good. The channel sends the release again each period."""
    ch = Channel(V2XSettings(loss=0.6, plausibility=False), movements, PERIOD, seed=3)
    drive(ch, movements, [k * PERIOD for k in range(20)])  # known to the controller
    assert "A" in ch.tracks
    ch.send(Decisions(release=["A"]), 1.9)
    released_at, sent = None, []
    for k in range(20, 60):
        drive(ch, movements, [k * PERIOD])  # it keeps sending its state
        got = ch.deliver(k * PERIOD)
        if got is not None and "A" in got.release and released_at is None:
            released_at = len(sent)
        sent.append(ch.counts["commands_sent"])
        ch.send(Decisions(), k * PERIOD)  # the controller sends it nothing more
    assert released_at is not None and released_at >= 1  # this seed loses the first release
    assert sent[-1] == sent[released_at] < 40  # nothing sent once one got through
    # a vehicle the controller commands again (the next junction) is not released behind its back
    ch2 = Channel(V2XSettings(loss=0.5, plausibility=False), movements, PERIOD, seed=3)
    drive(ch2, movements, [k * PERIOD for k in range(20)])
    for k in range(20, 60):  # until a release is lost
        ch2.send(Decisions(release=["A"]), k * PERIOD)
        if ch2.counts["commands_lost"]:
            break
    before = ch2.counts["commands_sent"]
    ch2.send(Decisions(accel={"A": 1.0}), 5.0)
    ch2.send(Decisions(), 5.1)
    assert ch2.counts["commands_sent"] == before + 1  # the acceleration only, no release after it


def test_position_offset_attack_is_rejected_and_predicted_conservatively(movements):
    attack = AttackSettings(vehicle="A", kind="position_offset", value=5.0, begin=0.5, end=0.8)
    ch = Channel(V2XSettings(attack=(attack,)), movements, PERIOD, seed=1)
    times = [round(k * PERIOD, 6) for k in range(8)]
    seen = drive(ch, movements, times, s0=20.0, v=8.0)
    assert ch.counts["attacked"] == 3 and ch.counts["rejected"] == 3 and ch.counts["missed"] == 0
    assert ch.tracks["A"].suspect and ch.tracks["A"].accepted.stamp == pytest.approx(0.4)
    r = reach(20.0 + 3.2, 8.0, 0.3, 3.0, 4.5, 20.0)
    assert seen[-1].s[0] == pytest.approx(r.s_hi) and seen[-1].v[0] == pytest.approx(r.v_hi)
    assert seen[-1].s[0] > 20.0 + 8.0 * 0.7  # ahead of where it is: nearer the crossing
    plain = Channel(V2XSettings(attack=(attack,), plausibility=False), movements, PERIOD, seed=1)
    fooled = drive(plain, movements, times, s0=20.0, v=8.0)
    assert plain.counts["missed"] == 3 and fooled[-1].s[0] == pytest.approx(20.0 + 8.0 * 0.7 + 5.0)


def test_silent_and_replay_attacks(movements):
    silent = AttackSettings(vehicle="A", kind="silent", begin=0.3, end=1.0)
    ch = Channel(V2XSettings(attack=(silent,)), movements, PERIOD, seed=1)
    drive(ch, movements, [round(k * PERIOD, 6) for k in range(6)])
    assert ch.counts["messages_silenced"] == 3 and ch.tracks["A"].accepted.stamp == pytest.approx(0.2)
    replay = AttackSettings(vehicle="A", kind="replay", value=0.5, begin=0.6, end=1.0)
    ch = Channel(V2XSettings(attack=(replay,)), movements, PERIOD, seed=1)
    drive(ch, movements, [round(k * PERIOD, 6) for k in range(7)])  # at 0.6 s it resends its 0.1 s state
    assert ch.counts["attacked"] == 1 and ch.counts["rejected"] == 1  # 5 m behind where it can be


def test_unknown_vehicles_are_left_out_and_other_fields_carry(movements):
    ch = Channel(V2XSettings(latency=0.1), movements, PERIOD, seed=1)
    a = truth(movements, 0.0, 20.0, 10.0, vid="A")
    ch.uplink(a)
    b = truth(movements, 0.1, 40.0, 5.0, vid="B")
    both = World(**{**{f.name: getattr(a, f.name) for f in dataclasses.fields(World)}, "time": 0.1,
                    "ids": ["A", "B"], "path_ids": [PID, PID], "s": np.array([21.0, 40.0]),
                    "v": np.array([10.0, 5.0]), "a": np.zeros(2), "x": np.r_[a.x, b.x], "y": np.r_[a.y, b.y],
                    "heading": np.r_[a.heading, b.heading], "kappa": np.array([0.3, 0.9]),
                    "role": ["ready", "ready"], "lanes": a.lanes * 2,
                    "exit_choices": {**a.exit_choices, **b.exit_choices}, "desired_speed": np.array([7.0, 9.0])})
    ch.uplink(both)
    seen = ch.observe(both)
    assert seen.ids == ["A"]  # B's first message is still under way
    assert seen.kappa.tolist() == [0.3] and seen.desired_speed.tolist() == [7.0]
    assert list(seen.exit_choices) == ["A"]


def test_a_sender_rejected_for_resync_seconds_is_taken_again(movements):
    """After a 5 m offset the true position lies behind what the spoofed track can reach: without a
    resync the sender would stay rejected (and the junction could lock)."""
    attack = AttackSettings(vehicle="A", kind="position_offset", value=5.0, begin=0.2, end=1.0)
    ch = Channel(V2XSettings(attack=(attack,), resync=0.5), movements, PERIOD, seed=1)
    times = [round(k * PERIOD, 6) for k in range(40)]
    seen = drive(ch, movements, times, s0=20.0, v=8.0)
    # taken at the spoofed state 0.5 s into the attack, then at the true one 0.5 s after it
    assert ch.counts["rejected"] == 5 and ch.counts["resyncs"] == 2 and ch.counts["false_rejections"] == 5
    assert not ch.tracks["A"].suspect and seen[-1].s[0] == pytest.approx(20.0 + 8.0 * times[-1])


def test_a_per_lane_field_is_the_roadside_view_and_carries_whole(movements):
    """exit_free is read by the junction's own sensing, not sent by vehicles: the channel keeps
    every lane's entry even for vehicles it has not heard from (else the exit rule would see
    every exit lane empty under V2X)."""
    ch = Channel(V2XSettings(latency=0.1), movements, PERIOD, seed=1)
    w = dataclasses.replace(truth(movements, 0.0, 20.0, 10.0), exit_free={"E1_0": (3.5, 0.0), "E2_0": (80.0, 9.0)})
    ch.uplink(w)
    later = dataclasses.replace(truth(movements, 0.1, 21.0, 10.0), exit_free={"E1_0": (4.0, 0.5)})
    ch.uplink(later)
    assert ch.observe(w).ids == []  # nothing has arrived yet
    assert ch.observe(w).exit_free == {"E1_0": (3.5, 0.0), "E2_0": (80.0, 9.0)}
    assert ch.observe(later).ids == ["A"] and ch.observe(later).exit_free == {"E1_0": (4.0, 0.5)}
