"""benchmark resco: its scenario files and its refusals, before any run."""

import tomllib

import pytest

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.benchmark import _names, resco_nets, write_scenarios


def _nets(tmp_path):
    (tmp_path / "nets" / "cologne1").mkdir(parents=True)
    (tmp_path / "nets" / "cologne1" / "cologne1.sumocfg").write_text("<configuration/>")
    return tmp_path / "nets"


def test_scenario_files_name_the_sumocfg_and_the_window(tmp_path):
    nets = _nets(tmp_path)
    (full,) = write_scenarios(["cologne1"], nets, "full", tmp_path / "a")
    (short,) = write_scenarios(["cologne1"], nets, "600", tmp_path / "b")
    a, b = tomllib.loads(full.read_text()), tomllib.loads(short.read_text())
    assert a["network"] == {"sumocfg": str(nets / "cologne1" / "cologne1.sumocfg"), "junctions": "all",
                            "signals": "off"}
    assert "duration" not in a["scenario"] and b["scenario"]["duration"] == 600


@pytest.mark.parametrize("call, field", [
    (lambda p: _names("cologne1,paris"), "scenarios"),
    (lambda p: resco_nets(str(p / "nowhere")), "nets"),
    (lambda p: write_scenarios(["cologne3"], _nets(p), "full", p / "out"), "nets"),
    (lambda p: write_scenarios(["cologne1"], _nets(p), "900", p / "out"), "window"),
])
def test_bad_benchmark_input_is_refused(tmp_path, call, field):
    with pytest.raises(InputError) as err:
        call(tmp_path)
    assert err.value.field == field
