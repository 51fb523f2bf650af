"""The shipped scenario files parse and place the paper's vehicles where the paper puts them."""

from pathlib import Path

import pytest

from intersection_cosim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"

CASE1 = {"V1": (2, -25), "V2": (18, 2), "V3": (-30, -2)}
CASE2 = {"V1": (-28, -6), "V2": (-6, 25), "V3": (-2, 16), "V5": (10, -50)}
CASE1_KAPPA = {"A": (0.5, 0.5, 0.5), "B": (0.5, 0.2, 0.2), "C": (0.8, 0.5, 0.5), "D": (0.8, 0.9, 0.5)}
CASE2_KAPPA = {"A": (0.5, 0.4, 0.85, 0.45, 0.5), "B": (0.9, 0.4, 0.2, 0.45, 0.5)}


@pytest.mark.parametrize("path", sorted(SCENARIOS.glob("*.toml")), ids=lambda p: p.stem)
def test_every_shipped_scenario_parses(path):
    scn = load_scenario(path)
    assert scn.vehicles or scn.flows


@pytest.mark.parametrize("variant", "ABCD")
def test_case1_start_points_speeds_and_kappa(variant):
    scn = load_scenario(SCENARIOS / f"case1_{variant}.toml")
    by_id = {v.id: v for v in scn.vehicles}
    for vid, (x, y) in CASE1.items():
        assert (by_id[vid].x, by_id[vid].y) == pytest.approx((x, y), abs=0.5)
        assert by_id[vid].movement == "left" and by_id[vid].lane == "inner"
        assert not by_id[vid].in_junction
    assert [by_id[v].speed for v in ("V1", "V2", "V3")] == [5.5, 4.5, 5.0]
    assert tuple(by_id[v].kappa for v in ("V1", "V2", "V3")) == CASE1_KAPPA[variant]
    assert [by_id[v].approach for v in ("V1", "V2", "V3")] == ["south", "east", "west"]


@pytest.mark.parametrize("variant", "AB")
def test_case2_start_points_and_v4_in_junction(variant):
    scn = load_scenario(SCENARIOS / f"case2_{variant}.toml")
    by_id = {v.id: v for v in scn.vehicles}
    for vid, (x, y) in CASE2.items():
        assert (by_id[vid].x, by_id[vid].y) == pytest.approx((x, y), abs=0.5)
    v4 = by_id["V4"]
    assert v4.in_junction and v4.path_id == "north_inner_left_inner"
    assert max(abs(v4.x), abs(v4.y)) < 12.0
    # The paper's (4, 2) is 2 m off SUMO's left-turn centre line; V4 sits at its nearest point.
    assert ((v4.x - 4) ** 2 + (v4.y - 2) ** 2) ** 0.5 == pytest.approx(2.0, abs=0.1)
    assert (by_id["V1"].lane, by_id["V1"].movement) == ("middle", "straight")
    assert (by_id["V3"].lane, by_id["V3"].movement, by_id["V3"].approach) == ("inner", "left", "north")
    assert (by_id["V5"].lane, by_id["V5"].movement, by_id["V5"].approach) == ("outer", "right", "south")
    assert tuple(by_id[f"V{i}"].kappa for i in range(1, 6)) == CASE2_KAPPA[variant]
    assert [by_id[f"V{i}"].speed for i in range(1, 6)] == [6.0, 5.0, 5.5, 5.0, 6.0]
    # "the low speed of V4": it keeps its 5 m/s; the others drive up to the model's v_max
    assert [by_id[f"V{i}"].desired_speed for i in range(1, 6)] == [None, None, None, 5.0, None]


def test_the_game_controllers_tables_set_their_settings():
    """[controller.game], [controller.solver], [controller.policy] and [controller.safety] each
    set their own settings object; the rest keep their defaults."""
    from intersection_cosim.control.game.settings import GameControllerSettings
    from intersection_cosim.scenario import scenario_from_dict

    data = {"scenario": {"name": "t", "duration": 5.0},
            "controller": {"kind": "stackelberg", "game": {"horizon": 4.0}, "solver": {"nash_tol": 0.02},
                           "policy": {"lane_choice_period": 3, "solo_reuse_residual": 0.0,
                                      "solo_position_tol": 0.2}, "safety": {"time_gap": 0.7}},
            "vehicle": [{"id": "V1", "approach": "south", "lane": "inner", "distance": 13.0, "movement": "left",
                         "speed": 5.5, "kappa": 0.5}]}
    settings = scenario_from_dict(data).controller_settings
    default = GameControllerSettings()
    assert isinstance(settings, GameControllerSettings)
    assert (settings.game.horizon, settings.game.steps, settings.game.dt) == (4.0, 40, default.game.dt)
    assert settings.solver.nash_tol == 0.02 and settings.policy.lane_choice_period == 3
    assert (settings.policy.solo_reuse_residual, settings.policy.solo_position_tol) == (0.0, 0.2)
    assert settings.policy.solo_speed_tol == default.policy.solo_speed_tol
    assert settings.safety.time_gap == 0.7 and settings.safety.margin == default.safety.margin
    assert settings.games.problem is settings.game and settings.games.solver is settings.solver


@pytest.mark.parametrize("case", ["case1_A", "case1_B", "case1_C", "case1_D", "case2_A", "case2_B"])
def test_paper_scenarios_run_the_game_unless_told_otherwise(case):
    """`run scenarios/case1_A.toml` and a kappa sweep of it play the paper's game (kappa matters),
    not SUMO's baseline (which ignores kappa)."""
    from intersection_cosim.control.game.settings import GameControllerSettings

    scn = load_scenario(SCENARIOS / f"{case}.toml")
    assert scn.controller.kind == "nash"
    assert scn.controller_settings == GameControllerSettings()  # no [controller.*] table: the defaults
