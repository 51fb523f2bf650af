"""One junction's share of a net's movements: what a per-junction controller manages.

:func:`junction_movements` restricts a :class:`~intersection_cosim.network.movements.Movements`
of several managed junctions to the paths of one of them (with their exits, siblings, lane
roles and SUMO's foe pairs), so a controller of one junction sees only its own movements.
"""

from __future__ import annotations

from intersection_cosim.network.movements import PASSING, READY, Movements


def path_junction(movements: Movements, path_id: str) -> str:
    """The managed junction path ``path_id`` crosses."""
    return movements.paths[path_id].junction or movements.junctions[0]


def junction_movements(movements: Movements, junction: str) -> Movements:
    """The movements of ``junction`` alone; ``movements`` itself when it manages no other."""
    if tuple(movements.junctions) == (junction,):
        return movements
    paths = {pid: p for pid, p in movements.paths.items() if path_junction(movements, pid) == junction}
    roles: dict[str, str] = {}
    for path in paths.values():
        roles.update({lane: READY for lane in path.lanes[:path.stop_index]})
        roles.update({lane: PASSING for lane in path.junction_lanes})
    return Movements(movements.net_file, (junction,), paths,
                     {pid: movements.exits[pid] for pid in paths},
                     {key: sib for key, sib in movements.siblings.items() if key[0] in paths},
                     roles, foes=frozenset(f for f in movements.foes if f[0] in paths and f[1] in paths),
                     control_range=movements.control_range, vclass=movements.vclass)
