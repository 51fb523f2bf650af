"""step_relations' vectorised leaders and lateral pairs equal the per-pair loop they replaced
(kept here as the reference), on random worlds of the default net."""

import math

import numpy as np
import pytest

from intersection_cosim.control.game.relations import Leader, Lateral, named_pairs, step_relations
from intersection_cosim.models.prediction import all_pairs
from intersection_cosim.models.risk import event_trigger
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflicts import KIND_CONFLUENCE, KIND_CROSS, KIND_FOLLOWING
from intersection_cosim.network.conflict_zones import point_zone
from tests.control.conftest import make_world

MODEL = ModelSettings()


def loop_relations(world, rows, active, table, model, etm):
    """The per-pair loop of step_relations before it was vectorised (the reference)."""
    i, j = all_pairs(len(rows))
    keep = rows.vehicle[i] != rows.vehicle[j]
    k_of, pidx = rows.vehicle, rows.pidx
    risk = event_trigger(table, pidx, world.s[k_of], world.v[k_of], world.kappa[k_of], model, pairs=(i[keep], j[keep]))
    s_now = (world.s[k_of[risk.i]], world.s[k_of[risk.j]])
    d = (risk.s_cp_i - s_now[0], risk.s_cp_j - s_now[1])
    clear = model.conflict_clearance
    leaders, lateral = {}, []
    for m in range(len(risk.i)):
        ri, rj = int(risk.i[m]), int(risk.j[m])
        d_i, d_j = d[0][m], d[1][m]
        if risk.leader_follower[m]:
            if min(d_i, d_j) < -clear and risk.kind[m] != KIND_CONFLUENCE:
                continue
            lead, follow = (ri, rj) if d_i < d_j else (rj, ri)
            s_cp_f = risk.s_cp_i[m] if follow == ri else risk.s_cp_j[m]
            s_cp_l = risk.s_cp_j[m] if follow == ri else risk.s_cp_i[m]
            gap = abs(d_i - d_j)
            if follow in leaders and leaders[follow].gap <= gap:
                continue
            until = s_cp_l + clear if risk.kind[m] == KIND_FOLLOWING else math.inf
            leaders[follow] = Leader(int(k_of[lead]), float(s_cp_f - s_cp_l), float(gap), float(until),
                                     bool(risk.kind[m] == KIND_CONFLUENCE))
        elif risk.kind[m] in (KIND_CROSS, KIND_CONFLUENCE):
            both = k_of[ri] in active and k_of[rj] in active
            if not both and k_of[ri] not in active and k_of[rj] not in active:
                continue
            s_i, s_j = float(risk.s_cp_i[m]), float(risk.s_cp_j[m])
            if risk.kind[m] == KIND_CROSS:
                kind, p_i, p_j = "cross", pidx[ri], pidx[rj]
                zone_i = (float(table.zone_in[p_i, p_j]), float(table.zone_out[p_i, p_j]))
                zone_j = (float(table.zone_in[p_j, p_i]), float(table.zone_out[p_j, p_i]))
            else:
                kind = "confluence"
                zone_i = point_zone(s_i, model.vehicle_length, model.vehicle_width)
                zone_j = point_zone(s_j, model.vehicle_length, model.vehicle_width)
            if s_now[0][m] > zone_i[1] or s_now[1][m] > zone_j[1]:
                continue
            live = both and not (d[0][m] < -clear or d[1][m] < -clear)
            play = live and (bool(risk.trigger[m]) or not etm)
            lateral.append(Lateral(ri, rj, kind, s_i, s_j, live, play, zone_i, zone_j))
    return leaders, lateral


def _random_world(paths, rng, n):
    pids = sorted(paths)
    vehicles = []
    for k in range(n):
        pid = pids[rng.integers(len(pids))]
        s_stop = paths[pid].s_stop
        s = float(rng.uniform(max(s_stop - 90.0, 0.5), min(s_stop + 35.0, paths[pid].length - 0.5)))
        v = float(rng.choice([0.0, rng.uniform(0.0, 14.0)]))
        vehicles.append((f"v{k}", pid, s, v))
    world = make_world(paths, 0.0, vehicles)
    world.kappa[:] = rng.uniform(0.2, 0.8, n)
    return world


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("etm", [True, False])
def test_vectorised_relations_equal_the_loop(paths, movements, conflict_table, seed, etm):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 60))
    world = _random_world(paths, rng, n)
    active = {k for k in range(n) if rng.random() < 0.85}
    rel = step_relations(world, active, movements, conflict_table, MODEL, etm, {}, 30.0)
    leaders, lateral = loop_relations(world, rel.rows, active, conflict_table, MODEL, etm)
    assert list(rel.leaders.items()) == list(leaders.items())  # same values, same key order
    assert list(rel.lateral) == lateral
    for lat in rel.lateral:  # exact Python types, as the loop built them
        assert type(lat.s_i) is float and type(lat.live) is bool and type(lat.zone_i[0]) is float
    assert [rel.pairs.at(m) for m in range(len(rel.pairs))] == lateral  # the columns, one by one
    vehicle = rel.rows.vehicle
    assert rel.triggered_pairs() == frozenset(tuple(sorted((int(vehicle[lat.ri]), int(vehicle[lat.rj]))))
                                              for lat in lateral if lat.play)
    assert (leaders and lateral) or n < 10  # the worlds exercise both


def test_named_pairs_matches_either_order_and_drops_vehicles_that_left():
    """The events' and the filter's lookup of vehicle-id pairs among index pairs, vectorised:
    the same answer as a per-pair set lookup of the sorted ids."""
    ids = ["north_0", "east_1", "south_2", "west_3"]
    names = frozenset({("east_1", "north_0"), ("south_2", "west_3"), ("gone_9", "north_0")})
    a = np.array([0, 1, 3, 0, 2, 1])
    b = np.array([1, 0, 2, 2, 2, 3])
    expected = [(min(ids[x], ids[y]), max(ids[x], ids[y])) in names for x, y in zip(a, b)]
    assert named_pairs(ids, names, a, b).tolist() == expected == [True, True, True, False, False, False]
    assert not named_pairs(ids, frozenset(), a, b).any()
