"""One run of one scenario: SUMO inputs (experiments/run_inputs.py) -> closed loop through libsumo
(experiments/closed_loop.py) -> CSVs and summary (experiments/run_tables.py).

With ``gui`` settings the same loop drives sumo-gui through TraCI instead, and a
:class:`~intersection_cosim.sim.gui.GuiView` draws each step's decisions; the outputs are the same.

Everything is written into a temporary folder beside the output folder and renamed into place
when the run has finished (experiments/output_folder.py), so a crashed or interrupted run leaves
no half-written results.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from intersection_cosim.experiments.closed_loop import simulate
from intersection_cosim.experiments.files import SUMO_LOG_FILE
from intersection_cosim.experiments.output_folder import finish_output, prepare_output
from intersection_cosim.experiments.run_inputs import write_inputs
from intersection_cosim.experiments.run_tables import result_tables, run_summary, vehicle_counts, write_tables
from intersection_cosim.results.layout import RUN_MARKER
from intersection_cosim.results.sumo_log import read_sumo_log
from intersection_cosim.scenario.model import Scenario


def run_scenario(scn: Scenario, out: str | Path, *, force: bool = False, fail_hook=None, gui=None,
                 compress_trajectories: bool = False) -> dict:
    """Run ``scn`` and write its results into ``out``; return the summary dict.

    ``out`` holding a finished run is refused (InputError) unless ``force``, which replaces it.
    ``gui`` (a :class:`~intersection_cosim.sim.gui.GuiSettings`) shows the run live in sumo-gui;
    None (the default) runs headless through libsumo. ``fail_hook`` (tests only) is called after
    the simulation loop, before the rename, so tests can simulate a crash at the worst moment.
    ``compress_trajectories``: write trajectories.csv.gz instead of trajectories.csv (a sweep's runs).
    """
    out = Path(out)
    if gui is not None:
        from intersection_cosim.sim.gui import check_display

        check_display()  # before anything is written
    tmp = prepare_output(out, force)
    try:
        summary = _run_into(scn, tmp, gui, compress_trajectories)
        if fail_hook is not None:
            fail_hook()
        finish_output(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return summary


def _run_into(scn: Scenario, folder: Path, gui=None, compress: bool = False) -> dict:
    """Run ``scn`` with every output written into ``folder``; return the summary dict."""
    inputs = write_inputs(scn, folder)
    simulated = simulate(scn, folder, inputs, gui)
    tables = result_tables(scn, folder, inputs, simulated)
    diagnostics = inputs.controller.diagnostics()
    write_tables(folder, tables, simulated.records, diagnostics, compress)
    own = len(scn.vehicles) + len(inputs.flow_vehicles)
    summary = run_summary(scn, simulated.infos, tables, diagnostics, gui, simulated.onboard_caps,
                          vehicle_counts(scn, own, simulated.loaded, tables.tripinfo),
                          simulated.onboard_crossing_caps)
    ended = simulated.records.ended
    summary["ended_early"] = ended[0]._asdict() if ended else None
    summary["sumo_warnings"] = read_sumo_log(folder / SUMO_LOG_FILE)
    summary["engineer"]["emission_classes"] = simulated.emission_classes
    if simulated.v2x_counts is not None:
        summary["v2x"] = dict(simulated.v2x_counts)
    with open(folder / RUN_MARKER, "w") as fh:
        json.dump(summary, fh, indent=2)
    return summary
