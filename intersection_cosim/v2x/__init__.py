"""Imperfect V2X between the vehicles and the controller.

A pure layer between ``control`` and ``scenario``: :class:`~intersection_cosim.v2x.channel.Channel`
turns the World the simulator reads into the World the controller sees (the last message that
arrived from each vehicle, extrapolated to now) and carries the controller's Decisions back with
the same latency and loss. It never imports the simulator.
"""

from intersection_cosim.v2x.channel import Channel
from intersection_cosim.v2x.settings import ATTACK_KINDS, AttackSettings, V2XSettings

__all__ = ["ATTACK_KINDS", "AttackSettings", "Channel", "V2XSettings"]
