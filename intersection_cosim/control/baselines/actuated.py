"""``sumo-actuated``: SUMO's actuated signal programme on the net's own traffic lights, the signal
baseline traffic engineers compare with.

Like ``sumo-tls`` it commands no vehicle (SUMO's driver model obeys the lights); the run loads,
for every traffic light of the managed junctions, SUMO's actuated programme built from the net's
own phases (network/signal_programmes.py): a green phase is extended while vehicles keep
arriving at SUMO's own detectors within the gap, between its minimum and maximum green.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

from intersection_cosim.control.baselines.signal_settings import SignalSettings
from intersection_cosim.control.baselines.sumo_baseline import SumoController
from intersection_cosim.network.signal_programmes import actuated_programmes


@dataclass
class ActuatedController(SumoController):
    junction_type: str = "traffic_light"
    settings: SignalSettings = field(default_factory=SignalSettings)

    def signal_additional(self, net_file: str, junctions: tuple[str, ...]) -> ET.Element:
        """The ``<additional>`` SUMO loads for this run: the actuated programmes of ``junctions``."""
        s = self.settings
        return actuated_programmes(net_file, junctions, s.min_green, s.max_green, s.max_gap, s.detector_gap)
