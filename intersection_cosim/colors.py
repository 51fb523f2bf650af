"""Colours a person reads a run by, shared by the live GUI (sim/gui.py) and the animation.

A controlled vehicle's colour is its aggressiveness kappa on one blue -> violet -> red scale
(cautious -> aggressive); a vehicle SUMO drives itself (a baseline's, or one released from
control) is grey; the pairs that play a game this step are marked amber. Colours are 0-255 RGB.
"""

from __future__ import annotations

KAPPA_RANGE = (0.0, 1.0)  # [-] the scenario files' range of kappa
# (kappa [-], RGB) stops of the kappa scale, linearly interpolated between them
KAPPA_STOPS = ((0.0, (40, 90, 210)), (0.5, (150, 60, 170)), (1.0, (215, 30, 30)))
UNCONTROLLED = (150, 150, 150)  # SUMO's own driver model drives the vehicle
HUMAN = (40, 170, 80)  # a human driver ([[vehicle]] driver = "human" or a flow's av_share < 1): SUMO drives it
GAME = (255, 190, 0)  # a pair that plays a game this step


def kappa_color(kappa: float) -> tuple[int, int, int]:
    """The RGB colour of ``kappa`` [-] (clipped to :data:`KAPPA_RANGE`)."""
    k = min(max(float(kappa), KAPPA_RANGE[0]), KAPPA_RANGE[1])
    for (k0, c0), (k1, c1) in zip(KAPPA_STOPS, KAPPA_STOPS[1:]):
        if k <= k1:
            w = (k - k0) / (k1 - k0)
            return tuple(int(round(a + w * (b - a))) for a, b in zip(c0, c1))
    return KAPPA_STOPS[-1][1]
