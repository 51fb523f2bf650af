"""The figures' content, drawn from fabricated runs and sweeps: what a reader is meant to see."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from matplotlib.patches import Polygon  # noqa: E402

from intersection_cosim.games.settings import SolverSettings  # noqa: E402
from intersection_cosim.report import run_figures, solver_figures, sweep_figures  # noqa: E402


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _traj() -> pd.DataFrame:
    """Three vehicles for 3 s at 0.1 s: V1 and V3 end on one exit lane, V2 crosses alone."""
    rows = []
    for k in range(31):
        t = round(0.1 * k, 2)
        role = "ready" if t < 1.0 else "passing" if t < 2.0 else "outside"
        rows.append((t, "V1", -20 + 10 * t, -6.0, 10.0, role, "west_in_1" if t < 2 else "east_out_1"))
        rows.append((t, "V2", 6.0, 20 - 5 * t, 5.0 - t, "ready" if t < 1.5 else "passing", "north_in_1"))
        rows.append((t, "V3", -30 + 10 * t, -6.0, 8.0, role, "west_in_2" if t < 2 else "east_out_1"))
    return pd.DataFrame(rows, columns=["time", "vehicle", "x", "y", "speed", "role", "lane"])


VEHICLES = pd.DataFrame({"vehicle": ["V1", "V2", "V3"], "kappa": [0.5, 0.2, 0.8]})


def test_trajectories_colour_by_time_and_spread_a_shared_lane():
    fig, ax = plt.subplots()
    drawn = run_figures.draw_trajectories(ax, _traj(), VEHICLES)
    assert run_figures.shared_lane_offsets(_traj()) == {"V1": -0.7, "V2": 0.0, "V3": 0.7}
    assert [len(drawn[v]) for v in ("V1", "V2", "V3")] == [7, 7, 7]  # every 0.5 s over 3 s
    assert drawn["V1"]["time"].tolist() == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
    # eastbound: left is north, so V1 (-0.7 m) is drawn south of the lane centre, V3 north, V2 on it
    assert drawn["V1"]["y"].to_numpy() == pytest.approx(-6.7) and drawn["V3"]["y"].to_numpy() == pytest.approx(-5.3)
    assert drawn["V2"]["x"].to_numpy() == pytest.approx(6.0)
    scatters = [c for c in ax.collections if c.get_array() is not None and len(c.get_array())]
    assert len(scatters) == 3 and scatters[0].get_array().tolist() == pytest.approx(drawn["V1"]["time"].tolist())
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["V1 ($\\kappa$ = 0.50)", "V2 ($\\kappa$ = 0.20)", "V3 ($\\kappa$ = 0.80)", "start",
                      "conflict zone"]
    assert [t.get_text() for t in ax.texts] == ["V1", "V2", "V3"]  # the start squares are named
    assert fig.axes[-1].get_ylabel() == "time [s]"  # the colour bar


def test_zone_events_are_the_first_passing_and_the_first_outside_after_it():
    events = run_figures.zone_events(_traj()).set_index("vehicle")
    assert events.loc["V1", ["entry_time", "exit_time"]].tolist() == pytest.approx([1.0, 2.0])
    assert events.loc["V2", "entry_time"] == pytest.approx(1.5) and np.isnan(events.loc["V2", "exit_time"])
    assert events.loc["V2", "entry_speed"] == pytest.approx(3.5)


def test_velocity_marks_entry_and_exit_of_the_conflict_zone():
    fig, ax = plt.subplots()
    run_figures.draw_velocity(ax, _traj(), VEHICLES)
    marks = {line.get_gid(): (line.get_xdata()[0], line.get_ydata()[0]) for line in ax.lines if line.get_gid()}
    assert marks == {"entry:V1": (1.0, 10.0), "exit:V1": (2.0, 10.0), "entry:V2": (1.5, 3.5),
                     "entry:V3": (1.0, 8.0), "exit:V3": (2.0, 8.0)}
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels[-3:] == ["enters the conflict zone", "leaves the conflict zone", "inside the conflict zone"]
    styles = [line.get_linestyle() for line in ax.lines if line.get_label().startswith("V")]
    assert len(set(styles)) == 3  # one line style per vehicle, not colour alone


def _convergence() -> pd.DataFrame:
    rows = [(0.65, "V1", "V3", "nash", "converged", m + 1, r) for m, r in enumerate([1.5, 0.3, 0.05, 0.004])]
    rows += [(0.75, "V1", "V3", "nash", "converged", 1, 0.002)]  # a shorter solve of the same pair
    rows += [(2.45, "V1", "V2", "nash", "converged", m + 1, r) for m, r in enumerate([0.8, 0.0])]
    return pd.DataFrame(rows, columns=["time", "vehicle_a", "vehicle_b", "solver", "status", "iteration", "residual"])


def test_convergence_draws_the_tolerance_on_an_axis_that_shows_the_iterations():
    fig, ax = plt.subplots()
    tol = SolverSettings().nash_tol
    drawn = solver_figures.draw_convergence(ax, _convergence(), tol, guard=0.3, rtol=1e-3)
    assert drawn["V1-V3"]["iteration"].tolist() == [1, 2, 3, 4]  # the longest solve of the pair
    assert drawn["V1-V2"]["residual"].tolist() == [0.8, solver_figures.RESIDUAL_FLOOR]  # 0 drawn at the floor
    lines = {line.get_gid(): line for line in ax.lines if line.get_gid()}
    assert list(lines["tolerance"].get_ydata()) == [tol, tol] and tol == 1e-2
    assert list(lines["guard"].get_ydata()) == [0.3, 0.3]
    assert ax.get_yscale() == "log"
    lo, hi = ax.get_ylim()
    assert solver_figures.RESIDUAL_FLOOR / 2 < lo < solver_figures.RESIDUAL_FLOOR and hi == pytest.approx(3.0)
    assert ax.get_xlim() == (0.5, 4.5)
    assert all(float(x).is_integer() for x in ax.get_xticks() if 0.5 <= x <= 4.5)
    assert "max change of any player's plan" in ax.get_ylabel() and "[m/s$^2$]" in ax.get_ylabel()
    assert "drawn at 0.0001" in ax.get_xlabel()


def test_ecdf_reaches_one_and_states_median_and_mean():
    fig, ax = plt.subplots()
    drawn = solver_figures.draw_ecdf(ax, {"ETM": np.array([3.0, 1.0, 2.0]), "no ETM": np.array([0.0, 4.0])},
                              extra={"ETM": "1.00 QPs per step"})
    assert drawn["ETM"].tolist() == [1.0, 2.0, 3.0]
    assert ax.get_xscale() == "log"
    assert ax.lines[0].get_ydata()[-1] == 1.0
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["ETM: median 2.00 ms, mean 2.00 ms, 1.00 QPs per step", "no ETM: median 2.00 ms, mean 2.00 ms"]


def _sweep_table() -> pd.DataFrame:
    rows = []
    for seed in (1, 2):
        for k in (0.1, 0.3, 0.5, 0.7, 0.9):
            rows.append({"run_id": f"nash-seed{seed}-V2_{k:.2f}", "controller": "nash", "seed": seed, "kappa_V2": k,
                         "travel_time_V2": 12.0 - 2 * k + 0.1 * seed, "mean_travel_time": 11.0,
                         "min_ttc_V1_V2": 2.5 - k, "min_ttc_V2_V3": 2.4 - k, "min_ttc_V1_V3": 0.1,
                         "min_ttc_ssm_V1_V2": 0.01, "pet_V1_V2": 1.3 - k, "pet_V1_V3": 0.05,
                         "min_ttc": 0.1, "min_pet": 0.05, "collisions": 0, "status": "ok"})
    return pd.DataFrame(rows)


def test_kappa_tradeoff_has_one_labelled_point_per_kappa_value():
    fig, axes = plt.subplots(1, 2)
    points = sweep_figures.draw_kappa_tradeoff(axes, _sweep_table(), "V2")
    assert points["kappa"].tolist() == [0.1, 0.3, 0.5, 0.7, 0.9]
    assert points["travel_time"].tolist() == pytest.approx([12.15 - 2 * k for k in (0.1, 0.3, 0.5, 0.7, 0.9)])
    # V2's own conflicts only (not V1-V3's 0.1 s, not SSM's TTC)
    assert points["min_ttc"].tolist() == pytest.approx([2.4 - k for k in (0.1, 0.3, 0.5, 0.7, 0.9)])
    assert points["min_pet"].tolist() == pytest.approx([1.3 - k for k in (0.1, 0.3, 0.5, 0.7, 0.9)])
    for ax in axes:
        labels = [t.get_text() for t in ax.texts if t.get_gid() == "kappa-label"]
        assert labels == [f"$\\kappa$ {k:g}" for k in (0.1, 0.3, 0.5, 0.7, 0.9)]
        assert ax.get_xlabel() == "travel time of V2 [s]"
    assert axes[0].get_ylabel() == "min TTC of V2's conflicts, ours [s]"
    assert axes[1].get_ylabel() == "min PET of V2's conflicts, SUMO SSM [s]"


def test_kappa_values_are_labelled_once_when_two_controllers_share_them():
    one = _sweep_table()
    two = pd.concat([one, one.assign(controller="stackelberg")], ignore_index=True)
    fig, axes = plt.subplots(1, 2)
    points = sweep_figures.draw_kappa_tradeoff(axes, two, "V2")
    assert len(points) == 10  # five kappa values under each controller
    for ax in axes:
        labels = [t.get_text() for t in ax.texts if t.get_gid() == "kappa-label"]
        assert labels == [f"$\\kappa$ {k:g}" for k in (0.1, 0.3, 0.5, 0.7, 0.9)]  # not printed twice


def test_kappa_labels_of_points_in_one_place_are_one_range_and_never_overlap(tmp_path):
    """The safety filter's gap holds an aggressive end in one place (V2 at kappa 0.7-0.9 within
    0.01 s of each other in travel time and margin): one label "kappa 0.7-0.9" there, and no two
    label boxes of a panel overlap once drawn."""
    rows = []
    for k in (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9):
        end = 0.05 * (k - 0.7) if k >= 0.7 else None  # [s] the held end moves by hundredths
        rows.append({"run_id": f"nash-seed1-V2_{k:.2f}", "controller": "nash", "seed": 1, "kappa_V2": k,
                     "travel_time_V2": 10.6 + end if end is not None else 13.0 - 3 * k,
                     "min_ttc_V2_V3": 1.6 - end if end is not None else 3.6 - 2.6 * k,
                     "pet_V1_V2": 0.55 - end if end is not None else 2.1 - 2.2 * k,
                     "mean_travel_time": 11.0, "collisions": 0, "status": "ok"})
    table = pd.DataFrame(rows)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), layout="constrained")
    sweep_figures.draw_kappa_tradeoff(axes, table, "V2")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for ax in axes:
        texts = [t for t in ax.texts if t.get_gid() == "kappa-label"]
        assert [t.get_text() for t in texts] == [f"$\\kappa$ {k:g}" for k in (0.1, 0.2, 0.3, 0.4, 0.5, 0.6)] + \
            ["$\\kappa$ 0.7-0.9"]
        boxes = [t.get_window_extent(renderer) for t in texts]
        assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    assert sweep_figures.kappa_tradeoff(table, "V2", tmp_path / "t.png").stat().st_size > 10_000


def test_values_of_two_controllers_at_one_kappa_are_written_above_and_below():
    one = _sweep_table()
    two = pd.concat([one, one.assign(controller="stackelberg", mean_travel_time=one["mean_travel_time"] + 0.05)],
                    ignore_index=True)
    fig, ax = plt.subplots()
    sweep_figures.draw_kappa_lines(ax, two, "mean_travel_time", "kappa_V2")
    labels = [t for t in ax.texts if t.get_gid() == "value-label"]
    assert len(labels) == 10  # five kappa values, two controllers
    for x in (0.1, 0.3, 0.5, 0.7, 0.9):
        here = sorted((t for t in labels if t.xy[0] == pytest.approx(x)), key=lambda t: t.xy[1])
        assert [t.xyann[1] > 0 for t in here] == [False, True]  # the lower value below, the higher above


def test_a_constant_zero_metric_gets_an_axis_from_zero_with_the_count_shown():
    fig, ax = plt.subplots()
    table = _sweep_table()[lambda d: d["kappa_V2"].isin([0.1, 0.9])]
    sweep_figures.draw_kappa_lines(ax, table, "collisions", "kappa_V2")
    lo, hi = ax.get_ylim()
    assert lo < 0 < hi == 1.0 and lo > -0.1
    assert "0 in every run (4 runs)" in [t.get_text() for t in ax.texts]
    assert list(ax.get_xticks()) == [0.1, 0.9]
    assert ax.lines[0].get_markersize() == 8  # two points: large markers


def test_a_run_on_a_net_file_is_drawn_around_its_junction_in_the_nets_frame(tmp_path, monkeypatch):
    """SUMO's cross has its junction at (500, 500) m: the trajectory figure centres there, draws
    the net's own lanes and outlines the managed junction, not the paper's schematic at (0, 0)."""
    import json
    import shutil

    import sumo
    import sumolib

    net = Path(sumo.SUMO_HOME) / "tools" / "game" / "cross" / "cross.net.xml"
    shutil.copyfile(net, tmp_path / "intersection.net.xml")
    network = {"file": str(net), "junctions": ["0"], "control_range": 50.0}
    (tmp_path / "summary.json").write_text(json.dumps({"settings": {"network": network}}))
    node = sumolib.net.readNet(str(net)).getNode("0")
    cx, cy = node.getCoord()[:2]
    traj = _traj()
    traj["x"], traj["y"] = traj["x"] + cx, traj["y"] + cy
    traj.to_csv(tmp_path / "trajectories.csv", index=False)
    VEHICLES.to_csv(tmp_path / "vehicles.csv", index=False)
    monkeypatch.setattr(plt, "close", lambda *a, **k: None)  # keep the figure to look at it
    run_figures.trajectory_figure(tmp_path, tmp_path / "trajectory.png")
    ax = plt.gcf().axes[0]
    assert ax.get_xlim() == pytest.approx((cx - 35.0, cx + 35.0))  # the farthest point 30 m out, + 5 m
    assert ax.get_ylim() == pytest.approx((cy - 35.0, cy + 35.0))
    assert "net's frame" in ax.get_xlabel()
    shape = np.asarray([p[:2] for p in node.getShape()])
    zones = [p for p in ax.patches if isinstance(p, Polygon) and not p.get_fill()]
    assert len(zones) == 1 and np.allclose(zones[0].get_xy()[:len(shape)], shape)
    lanes = [p for p in ax.patches if isinstance(p, Polygon) and p.get_fill()]
    assert len(lanes) >= 8  # [-] the net's lanes (2 in, 2 out on each of 4 arms at least)


def test_a_large_group_on_common_lanes_is_not_spread_off_its_road():
    rows = [(0.1 * k, f"V{i}", 0.0, 0.0, "west_in_1") for i in range(5) for k in range(3)]
    traj = pd.DataFrame(rows, columns=["time", "vehicle", "x", "y", "lane"])
    assert set(run_figures.shared_lane_offsets(traj).values()) == {0.0}  # five: drawn on their path
    four = run_figures.shared_lane_offsets(traj[traj["vehicle"] != "V4"])
    assert sorted(four.values()) == pytest.approx([-2.1, -0.7, 0.7, 2.1])  # four: side by side


def test_a_demand_run_gets_no_start_labels_that_would_pile_up():
    rows = [(0.1 * k, f"f.{i}", -30.0 + k, -6.0, 10.0, "ready", "west_in_1") for i in range(13) for k in range(6)]
    traj = pd.DataFrame(rows, columns=["time", "vehicle", "x", "y", "speed", "role", "lane"])
    fig, ax = plt.subplots()
    run_figures.draw_trajectories(ax, traj)
    assert len(ax.texts) == 0 and ax.get_legend() is None  # 13 vehicles from one entry: no ids, no legend
    fig, ax = plt.subplots()
    run_figures.draw_trajectories(ax, traj[traj["vehicle"].isin([f"f.{i}" for i in range(12)])])
    assert len(ax.texts) == 12 and ax.get_legend() is not None


def test_grouped_bars_turn_long_group_names_so_they_do_not_run_together(tmp_path, monkeypatch):
    """Eight RESCO scenario names under the bars ran into each other ("ingolstadt1ingolstadt21");
    long or many names are turned 30 degrees, a few short ones stay level."""
    import matplotlib.pyplot as plt
    import pandas as pd

    from intersection_cosim.report import compare_figures

    angles = {}

    def keep_angles(fig, out):  # [deg] the tick labels' rotation, instead of writing the PNG
        angles[out.name] = [t.get_rotation() for t in fig.axes[0].get_xticklabels()]
        plt.close(fig)
        return out

    monkeypatch.setattr(compare_figures, "save_figure", keep_angles)
    names = ["arterial4x4", "cologne1", "cologne3", "cologne8", "grid4x4", "ingolstadt1", "ingolstadt21", "ingolstadt7"]
    values = pd.DataFrame({"nash": range(8), "max-pressure": range(8)}, index=names)
    compare_figures.grouped_bars(values, "delay [s]", tmp_path / "long.png")
    compare_figures.grouped_bars(values.iloc[:3].set_axis(["low", "mid", "high"]), "delay [s]", tmp_path / "short.png")
    assert set(angles["long.png"]) == {30.0} and set(angles["short.png"]) == {0.0}
