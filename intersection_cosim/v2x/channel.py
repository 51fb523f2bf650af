"""The V2X link: the World the controller sees and the Decisions that reach the vehicles.

Up: every ``period`` each vehicle in the simulator's World sends its state (path, arc length,
speed, acceleration, exit lanes it may take), with Gaussian noise on position and speed and any
``[[v2x.attack]]`` applied; each message is lost with probability ``loss`` and otherwise arrives
``latency`` later (at the first simulation step at or after that time).

What the controller sees (:meth:`Channel.observe`): only vehicles from which a message has been
accepted. A vehicle no message has arrived from yet is unknown to the controller: it is not in
the World, gets no command and drives on SUMO's own model meanwhile (it is inserted at the start
of its arm, far from the crossings, and is known one latency later unless its messages are lost).
A known vehicle is shown at its track's estimate (its accepted messages fused by a Kalman filter,
v2x/tracker.py) extrapolated to now along its path (dead reckoning at the last message's constant
acceleration, clipped at v >= 0; x, y and heading are those of the path at the extrapolated arc
length, lane and role follow from it). A vehicle that leaves
the simulation is dropped (the infrastructure knows a vehicle has left the network).

Plausibility (on by default): a message is rejected when its stamp is not newer than the
sender's last accepted message, or its position or speed lies outside what the sender can have
reached from that message within ``max_accel``, ``max_decel`` and ``max_speed`` (plus a
tolerance for noise, :func:`reckoning.tolerances`); ``max_decel`` is raised for a sender the
controller itself told to brake harder (an emergency stop for a pedestrian,
control/safety/pedestrians.py): the infrastructure knows what it commanded, and rejecting that braking
would show the vehicle farther on and faster than it is to the one behind it. The sender is then predicted conservatively
until a message is accepted again, from its last accepted state and the interval it can have
reached since (:func:`reckoning.reach`), at the end of that interval that is worse for the
others: a sender last seen before its stop line is shown as far along and as fast as it can be
(``s_hi``, ``v_hi``) but no farther than the stop line -- arriving at the crossing as early as
physically possible, so the others yield to it and its own commands brake for it soonest, and
never believed past a crossing it may not have reached; a sender last seen inside the junction
is shown braking as hard as it can (``s_lo``, ``v_lo``) -- the latest it can leave the crossings,
so they stay occupied for the others. A sender whose messages have been rejected for ``resync``
seconds in a row is taken at its newest message again (``resyncs`` counts it): without that a
vehicle that a wrong track made stop short of where it was believed could never be accepted
again (its true position behind every position the old track can reach), and the junction
would lock.

Down: the Decisions of a control step travel per vehicle (acceleration, exit lane, release) with
the same latency and loss; a vehicle whose command is lost keeps its last one (the simulator
holds each vehicle's acceleration until a new one arrives).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from intersection_cosim.control.base import Decisions, World
from intersection_cosim.network.movements import READY, Movements
from intersection_cosim.v2x.attacks import History, attacked
from intersection_cosim.v2x.messages import Command, StateMessage
from intersection_cosim.v2x.reckoning import dead_reckon, reach, tolerances
from intersection_cosim.v2x.settings import V2XSettings
from intersection_cosim.v2x.tracker import TrackState, fuse, start

EPS = 1e-9  # [s] time comparisons
STOP_LINE_GAP = 0.5  # [m] a suspect sender approaching is held this far before its stop line (still "ready")
HARD_HOLD = 1.0  # [s] how long after it was sent a hard braking command is counted on (commands come every period)
COUNTERS = ("messages_sent", "messages_lost", "messages_silenced", "attacked", "attacked_lost", "rejected",
            "missed", "false_rejections", "resyncs", "commands_sent", "commands_lost")


@dataclasses.dataclass
class Track:
    """What the controller knows of one sender."""

    accepted: StateMessage  # its last accepted message
    state: TrackState  # the Kalman estimate fused from its accepted messages (v2x/tracker.py)
    suspect: bool = False  # its newest message was rejected: predicted conservatively
    rejected_since: float | None = None  # [s] stamp of the first of its messages rejected in a row


class Channel:
    """Messages between the vehicles and the controller; see the module docstring."""

    def __init__(self, settings: V2XSettings, movements: Movements, control_period: float, seed: int):
        self.settings = settings
        self.movements = movements
        self.period = settings.period or control_period  # [s]
        self._up_loss = np.random.default_rng([seed, 1])
        self._noise = np.random.default_rng([seed, 2])
        self._down_loss = np.random.default_rng([seed, 3])
        replay = max([a.value for a in settings.attack if a.kind == "replay"], default=0.0)
        self._history = History(replay + self.period)
        self._replayers = {a.vehicle for a in settings.attack if a.kind == "replay"}
        self._up: list[StateMessage] = []  # in flight, in send order
        self._down: list[Command] = []
        self.tracks: dict[str, Track] = {}
        self.counts = dict.fromkeys(COUNTERS, 0)
        # per vehicle, the commands sent to it braking harder than max_decel: (send time [s], decel [m/s^2])
        self._hard: dict[str, list[tuple[float, float]]] = {}
        self._unreleased: set[str] = set()  # vehicles whose release was lost: sent again every period

    # --- up: states ------------------------------------------------------------------------
    def sends_at(self, time: float) -> bool:
        """Whether the vehicles send their states at ``time`` [s] (every ``period`` from 0)."""
        k = round(time / self.period)
        return abs(time - k * self.period) < 1e-6

    def uplink(self, world: World) -> None:
        """Every vehicle of the simulator's ``world`` sends its state (noise, attacks, loss)."""
        sigma_s, sigma_v = self.settings.position_noise, self.settings.speed_noise
        for i, vid in enumerate(world.ids):
            noise = self._noise.standard_normal(2)
            lost = self._up_loss.random() < self.settings.loss
            msg = StateMessage(sender=vid, stamp=world.time, arrival=world.time + self.settings.latency,
                               path_id=world.path_ids[i], s=float(world.s[i]) + sigma_s * noise[0],
                               v=max(0.0, float(world.v[i]) + sigma_v * noise[1]), a=float(world.a[i]),
                               exit_choices=tuple(world.exit_choices.get(vid, ())))
            if vid in self._replayers:
                self._history.add(msg)
            msg = self._attack(msg)
            if msg is None:
                self.counts["messages_silenced"] += 1
                continue
            self.counts["messages_sent"] += 1
            self.counts["attacked"] += msg.attacked
            if lost:
                self.counts["messages_lost"] += 1
                self.counts["attacked_lost"] += msg.attacked
                continue
            self._up.append(msg)

    def _attack(self, msg: StateMessage) -> StateMessage | None:
        for attack in self.settings.attack:
            if attack.vehicle == msg.sender and attack.active(msg.stamp):
                return attacked(msg, attack, self._history)
        return msg

    def _receive(self, time: float) -> None:
        """Take every state message that has arrived by ``time`` [s], oldest first."""
        arrived = [m for m in self._up if m.arrival <= time + EPS]
        self._up = [m for m in self._up if m.arrival > time + EPS]
        for msg in arrived:
            track = self.tracks.get(msg.sender)
            ok = track is None or not self.settings.plausibility or self.plausible(track.accepted, msg)
            if not ok and track.rejected_since is not None and \
                    msg.stamp - track.rejected_since >= self.settings.resync - EPS:
                ok = True  # rejected for resync seconds: take its newest message again
                self.counts["resyncs"] += 1
            if msg.attacked:
                self.counts["missed" if ok else "rejected"] += 1
            elif not ok:
                self.counts["false_rejections"] += 1
            if ok:
                self.tracks[msg.sender] = Track(msg, self._fused(track, msg))
            else:
                track.suspect = True
                if track.rejected_since is None:
                    track.rejected_since = msg.stamp

    def _fused(self, track: Track | None, msg: StateMessage) -> TrackState:
        """The sender's estimate with ``msg`` accepted: fused into its track, or a new track from
        ``msg`` alone for a first message, a resync, an attacked track's recovery or another
        approach lane (a position along another path)."""
        st, paths = self.settings, self.movements.paths
        fresh = track is None or track.suspect or track.accepted.path_id not in paths or \
            msg.path_id not in paths or paths[track.accepted.path_id].lanes[0] != paths[msg.path_id].lanes[0]
        if fresh:
            return start(msg.stamp, msg.s, msg.v, msg.a, st.position_noise, st.speed_noise)
        return fuse(track.state, msg.stamp, msg.s, msg.v, msg.a, st.position_noise, st.speed_noise, st.track_accel_noise)

    def plausible(self, last: StateMessage, msg: StateMessage) -> bool:
        """Whether ``msg`` is consistent with the sender's ``last`` accepted message and its limits."""
        st = self.settings
        dt = msg.stamp - last.stamp  # [s]
        if dt <= EPS:
            return False  # not newer: a duplicate or a replay with its old stamp
        tol_s, tol_v = tolerances(st.position_noise, st.speed_noise, dt)
        if not -tol_v <= msg.v <= st.max_speed + tol_v:
            return False
        paths = self.movements.paths
        if last.path_id not in paths or msg.path_id not in paths or \
                paths[last.path_id].lanes[0] != paths[msg.path_id].lanes[0]:
            return True  # another approach lane (the next managed junction): a new track, speed checked
        r = reach(last.s, last.v, dt, st.max_accel, self.decel_bound(msg.sender, last.stamp, msg.stamp),
                  st.max_speed)
        return r.s_lo - tol_s <= msg.s <= r.s_hi + tol_s and r.v_lo - tol_v <= msg.v <= r.v_hi + tol_v

    def decel_bound(self, vid: str, since: float, until: float) -> float:
        """[m/s^2] the hardest braking sender ``vid`` can have had between its messages stamped
        ``since`` and ``until`` [s]: ``max_decel``, or a harder braking the controller sent it that
        may have been in force then (sent before ``until``, no more than ``HARD_HOLD`` before
        ``since``: a vehicle holds a command until the next one arrives)."""
        bound = self.settings.max_decel
        for sent, decel in self._hard.get(vid, ()):
            if since - HARD_HOLD - self.settings.latency <= sent <= until:
                bound = max(bound, decel)
        return bound

    # --- what the controller sees ----------------------------------------------------------
    def estimate(self, vid: str, time: float) -> tuple[float, float, float]:
        """(s [m], v [m/s], a [m/s^2]) the controller assumes for known sender ``vid`` at ``time``."""
        track = self.tracks[vid]
        m, est, age = track.accepted, track.state, time - track.state.stamp
        est = dataclasses.replace(est, v=max(est.v, 0.0))
        if track.suspect:
            st = self.settings
            r = reach(est.s, est.v, age, st.max_accel, st.max_decel, st.max_speed)
            s_stop = self.movements.paths[m.path_id].s_stop
            if est.s < s_stop:  # approaching: as near the stop line (still before it) and as fast as it can be
                return min(r.s_hi, max(est.s, s_stop - STOP_LINE_GAP)), r.v_hi, 0.0
            return r.s_lo, r.v_lo, 0.0  # in the junction: as late to leave it as it can be
        s, v = dead_reckon(est.s, est.v, est.a, age)
        return s, v, (est.a if v > 0.0 else 0.0)

    def observe(self, world: World) -> World:
        """The World the controller sees at ``world.time``, built from the messages that arrived;
        ``world`` is the simulator's (only its vehicle ids and per-vehicle constants are read)."""
        self._receive(world.time)
        present = set(world.ids)
        self.tracks = {vid: t for vid, t in self.tracks.items() if vid in present}
        keep = [i for i, vid in enumerate(world.ids) if vid in self.tracks
                and self.tracks[vid].accepted.path_id in self.movements.paths]
        return self._world(world, keep)

    def _world(self, world: World, keep: list[int]) -> World:
        ids = [world.ids[i] for i in keep]
        cols = {k: np.empty(len(ids)) for k in ("s", "v", "a", "x", "y", "heading")}
        path_ids, lanes, roles, exits = [], [], [], {}
        for j, vid in enumerate(ids):
            msg = self.tracks[vid].accepted
            path = self.movements.paths[msg.path_id]
            s, v, a = self.estimate(vid, world.time)
            s = float(min(max(s, 0.0), path.length))
            lane = path.lane_at(s)[0]
            role = self.movements.role(lane)
            cols["s"][j], cols["v"][j], cols["a"][j] = s, v, a
            cols["x"][j], cols["y"][j] = path.point_at(s)
            cols["heading"][j] = path.heading_at(s)
            path_ids.append(msg.path_id)
            lanes.append(lane)
            roles.append(role)
            exits[vid] = msg.exit_choices if role == READY and msg.exit_choices else (path.exit_lane,)
        return dataclasses.replace(world.subset(keep), **cols, ids=ids, path_ids=path_ids, lanes=lanes,
                                   role=roles, exit_choices=exits)

    # --- down: commands --------------------------------------------------------------------
    def send(self, decisions: Decisions, time: float) -> None:
        """Put the controller's ``decisions`` of ``time`` [s] on the link, one command per vehicle.

        A lost release is sent again at every call until one gets through (an acknowledged
        message): the controller sends a vehicle it has let go nothing more, so with the release
        lost it kept its last acceleration after the junction for good (1.28 m/s^2 up to 12.7 m/s,
        into the vehicle ahead, fokr38 with 20 % loss). One the controller commands again (the
        next junction's) or that has left is dropped from the re-sending."""
        self._unreleased = {vid for vid in self._unreleased if vid in self.tracks and vid not in decisions.accel}
        release = set(decisions.release) | self._unreleased
        for vid in sorted(set(decisions.accel) | set(decisions.exit_lane) | release):
            self.counts["commands_sent"] += 1
            if self._down_loss.random() < self.settings.loss:
                self.counts["commands_lost"] += 1
                if vid in release:
                    self._unreleased.add(vid)
                continue
            self._unreleased.discard(vid)
            accel = decisions.accel.get(vid)
            self._down.append(Command(vid, time + self.settings.latency, accel,
                                      decisions.exit_lane.get(vid), vid in release, decisions.owner.get(vid)))
            if accel is not None and -accel > self.settings.max_decel:
                kept = [h for h in self._hard.get(vid, ()) if h[0] >= time - 2 * HARD_HOLD - self.settings.resync]
                self._hard[vid] = kept + [(time, -accel)]

    def deliver(self, time: float) -> Decisions | None:
        """The commands that reach their vehicles by ``time`` [s] (None: none), oldest first."""
        arrived = [c for c in self._down if c.arrival <= time + EPS]
        if not arrived:
            return None
        self._down = [c for c in self._down if c.arrival > time + EPS]
        out = Decisions()
        for c in arrived:
            if c.accel is not None:
                out.accel[c.vehicle] = c.accel
            if c.exit_lane is not None:
                out.exit_lane[c.vehicle] = c.exit_lane
            if c.release:
                out.release.append(c.vehicle)
            if c.owner is not None:  # the adapter takes it only while its junction owns the vehicle
                out.owner[c.vehicle] = c.owner
        return out

