"""RESCO's published average delays [s] for its two signal baselines, to be put next to ours.

Source: Ault and Sharon, "Reinforcement Learning Benchmarks for Traffic Signal Control" (NeurIPS
2021 Datasets and Benchmarks), repository Pi-Star-Lab/RESCO at commit fc65e91, file
``resco_benchmark/utils/avg_timeLoss.py``: the per-episode delays of their runs (their measure,
results/resco_delay.py), of which the values here are the means over the episodes listed. Their
``FIXED`` results (made outside the published code) are by name the net's own fixed-time
programme (our ``sumo-tls``); their ``MAXPRESSURE``
agent picks the phase of largest pressure at each of their decision steps (5 or 10 s by
scenario, 2-3 s yellow; our ``max-pressure``: sumo-rl's 5 s, 3 s yellow). Their
runs used SUMO 1.9 at its default 1 s step with ``--random`` seeds; ours use the scenario's step
(0.05 s by default), which lets queues discharge faster. (The README figure of that repository
colours the curves so that its "Max Pressure" line sits at their ``MAXWAVE`` values; we follow the
names of their code.)
"""

from __future__ import annotations

RESCO_SOURCE = ("Pi-Star-Lab/RESCO @ fc65e91, resco_benchmark/utils/avg_timeLoss.py "
                "(mean over their episodes; SUMO 1.9, 1 s steps)")

# scenario -> our controller -> (RESCO's mean delay [s], episodes); no entry: not published there
RESCO_PUBLISHED: dict[str, dict[str, tuple[float, int]]] = {
    "cologne1": {"sumo-tls": (56.6, 30), "max-pressure": (65.9, 30)},
    "cologne3": {"sumo-tls": (46.4, 30), "max-pressure": (162.3, 30)},
    "cologne8": {"sumo-tls": (63.8, 30), "max-pressure": (47.7, 100)},
    "ingolstadt1": {"sumo-tls": (39.4, 30), "max-pressure": (23.6, 30)},
    "ingolstadt7": {"sumo-tls": (91.3, 30), "max-pressure": (46.8, 100)},
    "ingolstadt21": {"sumo-tls": (133.1, 30), "max-pressure": (136.7, 100)},
    "arterial4x4": {"max-pressure": (952.7, 30)},
    "grid4x4": {"max-pressure": (52.6, 30)},
}
