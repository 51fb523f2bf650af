"""PathId: the text form of every path of the net round-trips, and with_exit swaps the exit lane."""

from __future__ import annotations

import pytest

from intersection_cosim.network.path_id import PathId


def test_str_is_the_id_of_the_paths_dict(paths):
    assert len(paths) == 28
    for pid, path in paths.items():
        parsed = PathId.parse(pid)
        assert str(parsed) == pid == path.id
        assert (parsed.approach, parsed.lane, parsed.movement, parsed.exit_lane) == \
            (path.approach, path.lane, path.movement, path.exit_lane)


def test_parse_and_str_round_trip():
    pid = PathId("south", "inner", "left", "middle")
    assert str(pid) == "south_inner_left_middle"
    assert PathId.parse("south_inner_left_middle") == pid
    assert hash(PathId.parse(str(pid))) == hash(pid)


def test_with_exit_keeps_approach_lane_and_movement(paths):
    pid = PathId.parse("north_inner_left_inner")
    other = pid.with_exit("middle")
    assert str(other) == "north_inner_left_middle" and str(other) in paths
    assert (other.approach, other.lane, other.movement) == ("north", "inner", "left")
    assert str(pid) == "north_inner_left_inner"  # frozen: the original is unchanged
    assert paths[str(other)].lanes[0] == paths[str(pid)].lanes[0]  # same approach lane in the net


@pytest.mark.parametrize("text", ["south_inner_left", "south_inner_left_middle_x", "up_inner_left_middle",
                                  "south_centre_left_middle", "south_inner_uturn_middle", ""])
def test_parse_rejects_malformed_ids(text):
    with pytest.raises(ValueError, match="path id"):
        PathId.parse(text)
