"""Traffic lights of a run: switched off at the managed junctions, or set by a signal controller."""

from __future__ import annotations

from typing import Mapping

from intersection_cosim.network.movements import OUTSIDE, Movements


def switch_signals_off(api, movements: Movements) -> list[str]:
    """Switch off every traffic light that controls a link into a managed junction (its state
    becomes O / o: no signal, so SUMO's own vehicles follow the junction's priority rules);
    returns the programmes' ids. ``api``: libsumo or a TraCI connection."""
    off = []
    for tls in api.trafficlight.getIDList():
        links = api.trafficlight.getControlledLinks(tls)
        if any(link and movements.role(link[0][0]) != OUTSIDE for link in links):
            api.trafficlight.setProgram(tls, "off")
            off.append(tls)
    return off


def set_signal_states(api, states: Mapping[str, str]) -> None:
    """Set each traffic light's state string (SUMO's ``rRgGyYoO`` per link) as a controller decided."""
    for tls, state in states.items():
        api.trafficlight.setRedYellowGreenState(tls, state)
