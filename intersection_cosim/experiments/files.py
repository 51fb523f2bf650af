"""SUMO input files of a run: the route file and the ``.sumocfg`` that sumo-gui opens too.

The exported ``.sumocfg`` sends SUMO's outputs into ``replay/`` beside it, so opening it later never
overwrites the run's own ``tripinfo.xml``, ``ssm.xml`` and ``collisions.xml``; the run itself puts
them in the run folder with :func:`run_output_options` on SUMO's command line.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from intersection_cosim.colors import HUMAN
from intersection_cosim.results.layout import QUEUES_FILE
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.network.paths import MovementPath
from intersection_cosim.network.spec import LANE_INDEX, exit_arm
from intersection_cosim.scenario.model import Scenario, VehicleSpec, VehicleType
from intersection_cosim.scenario.vtypes import sumo_type

ROUTE_FILE = "scenario.rou.xml"
SUMOCFG_FILE = "scenario.sumocfg"
SSM_THRESHOLDS = (3.0, 3.0, 2.0)  # TTC [s], DRAC [m/s^2], PET [s]: SUMO's defaults, for shares
SSM_RECORD_THRESHOLDS = "10.0 3.0 5.0"  # record encounters up to TTC 10 s / PET 5 s
SSM_RANGE = 50.0  # [m] SSM device search range
REPLAY_DIR = "replay"  # the exported config's SUMO outputs go here (relative to the config)
# SUMO option -> file name of each SUMO output of a run (in the run folder; in REPLAY_DIR on replay)
SUMO_OUTPUT_FILES = {"tripinfo-output": "tripinfo.xml", "collision-output": "collisions.xml",
                     "device.ssm.file": "ssm.xml"}
SIGNALS_FILE = "signals.add.xml"  # a signal baseline's traffic-light programmes, in the run folder
SUMO_LOG_FILE = "sumo.log"  # SUMO's warnings and errors of a run (its --error-log), in the run folder
REPLAY_README = """This folder receives SUMO's outputs when scenario.sumocfg (one level up) is opened with sumo or
sumo-gui. That replay runs SUMO's own driver model on the run's net and routes, NOT the game
controller, so its outputs differ from the run's own tripinfo.xml, ssm.xml and collisions.xml, which
it leaves untouched. To watch the controller drive, use: intersection-cosim run SCENARIO --gui
"""


def _write(root: ET.Element, path: Path) -> None:
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="UTF-8", xml_declaration=True)


def av_limits(scn: Scenario) -> tuple[float, float]:
    """[m/s^2] (accel, decel) of the vType ``av``: the game's limits a_max and -a_min (the
    ``[controller.game]`` table's, else ProblemSettings' defaults 2.5 and 4.0), so SUMO drives an
    AV before the controller takes it over and after it hands it back as the game plans it."""
    game = getattr(scn.controller_settings, "game", None)
    game = game if isinstance(game, ProblemSettings) else ProblemSettings()
    return game.a_max, -game.a_min


def write_routes(path: Path, scn: Scenario, paths: dict[str, MovementPath], flow_vehicles: list[dict]) -> None:
    """vType ``av`` (accel / decel: :func:`av_limits`) plus one ``<vehicle>`` per hand-placed and
    flow-generated vehicle, by depart.

    Vehicles of the paper forms are placed on ``paths`` (the generated net's movement paths);
    those with a ``route`` (a ``[network] file`` net) carry their edges, lane and position.
    A ``[network] routes`` file is not copied: :func:`route_files` lists it beside this one.
    """
    m = scn.model
    accel, decel = av_limits(scn)  # [m/s^2]
    root = ET.Element("routes")
    ET.SubElement(root, "vType", id="av", length=f"{m.vehicle_length:g}", width=f"{m.vehicle_width:g}",
                  minGap="2.0", accel=f"{accel:g}", decel=f"{decel:g}", emergencyDecel="9.0", sigma="0",
                  maxSpeed=f"{m.v_max:g}", speedFactor="1", tau="1.0")
    used = {sumo_type(scn.vtype(v.vtype), v.driver) for v in scn.vehicles}
    used |= {sumo_type(scn.vtype(fv.get("vtype")), fv.get("driver", "av")) for fv in flow_vehicles}
    if "human" in used:
        _human_vtype(root, scn)
    for vt in scn.vtypes:
        for driver in ("av", "human"):
            if not vt.from_routes and sumo_type(vt, driver) in used and (vt.driver == "av" or driver == "human"):
                _scenario_vtype(root, scn, vt, driver)
    entries = [_placed_entry(v) if v.route is not None else _paper_placed_entry(scn, v, paths)
               for v in scn.vehicles]
    entries += [_flow_entry(fv) if fv.get("route") is not None else _paper_flow_entry(scn, fv, paths)
                for fv in flow_vehicles]
    types = {v.id: sumo_type(scn.vtype(v.vtype), v.driver) for v in scn.vehicles}
    types |= {fv["id"]: sumo_type(scn.vtype(fv.get("vtype")), fv.get("driver", "av")) for fv in flow_vehicles}
    begin = scn.scenario.begin or 0.0  # [s] the scenario's own departs count from it
    for entry in entries:
        entry[2]["type"] = types[entry[1]]
        if begin:
            entry[2]["depart"] = f"{float(entry[2]['depart']) + begin:.2f}"
    entries.sort(key=lambda e: (e[0], e[1]))
    for _, _, attrs, edges in entries:
        el = ET.SubElement(root, "vehicle", attrs)
        ET.SubElement(el, "route", edges=edges)
    _write(root, path)


def _human_vtype(root: ET.Element, scn: Scenario) -> None:
    """vType ``human``: the [human] table's SUMO car-following model, the body of an ``av``, its own colour."""
    m, h = scn.model, scn.human
    attrs = dict(id="human", length=f"{m.vehicle_length:g}", width=f"{m.vehicle_width:g}", minGap=f"{h.min_gap:g}",
                 accel=f"{h.accel:g}", decel=f"{h.decel:g}", emergencyDecel=f"{h.emergency_decel:g}",
                 maxSpeed=f"{m.v_max:g}", speedFactor=f"{h.speed_factor:g}", tau=f"{h.tau:g}",
                 carFollowModel=h.model, color=",".join(str(c) for c in HUMAN))
    if scn.network.generated:  # it keeps the lane it was inserted on, as the AVs do (its path is known)
        attrs.update(lcSpeedGain="0", lcKeepRight="0")
    if h.model == "Krauss":
        attrs["sigma"] = f"{h.sigma:g}"
    else:
        attrs["delta"] = f"{h.delta:g}"
    ET.SubElement(root, "vType", attrs)


def _scenario_vtype(root: ET.Element, scn: Scenario, vt: VehicleType, driver: str) -> None:
    """The SUMO vType of [[vtype]] ``vt`` for vehicles of ``driver``: its body, limits and colour;
    an AV's driving attributes as vType ``av``'s, a human's as vType ``human``'s ([human])."""
    m, h = scn.model, scn.human
    attrs = dict(id=sumo_type(vt, driver), length=f"{vt.length or m.vehicle_length:g}",
                 width=f"{vt.width or m.vehicle_width:g}", maxSpeed=f"{vt.max_speed or m.v_max:g}")
    if driver == "av":
        accel, decel = av_limits(scn)  # [m/s^2] the defaults of vType av
        attrs.update(minGap=f"{2.0 if vt.min_gap is None else vt.min_gap:g}", accel=f"{vt.accel or accel:g}",
                     decel=f"{vt.decel or decel:g}", emergencyDecel=f"{max(9.0, vt.decel or 0.0):g}", sigma="0",
                     speedFactor="1", tau="1.0")
    else:
        attrs.update(minGap=f"{h.min_gap if vt.min_gap is None else vt.min_gap:g}", accel=f"{vt.accel or h.accel:g}",
                     decel=f"{vt.decel or h.decel:g}", emergencyDecel=f"{max(h.emergency_decel, vt.decel or 0.0):g}",
                     speedFactor=f"{h.speed_factor:g}", tau=f"{h.tau:g}", carFollowModel=h.model)
        attrs.update({"sigma": f"{h.sigma:g}"} if h.model == "Krauss" else {"delta": f"{h.delta:g}"})
        if scn.network.generated:
            attrs.update(lcSpeedGain="0", lcKeepRight="0")
    if vt.color:
        attrs["color"] = ",".join(str(c) for c in vt.color)
    elif driver == "human":
        attrs["color"] = ",".join(str(c) for c in HUMAN)
    ET.SubElement(root, "vType", attrs)


RouteEntry = tuple[float, str, dict[str, str], str]  # depart [s], id, <vehicle> attributes, route edges


def _paper_placed_entry(scn: Scenario, v: VehicleSpec, paths: dict[str, MovementPath]) -> RouteEntry:
    p = paths[v.path_id]
    approach_len = p.lane_starts[1]  # [m]
    pos = min(v.s0, approach_len - 0.1)  # [m]
    attrs = {"id": v.id, "type": v.driver, "depart": f"{v.depart:g}",
             "departLane": str(LANE_INDEX[v.lane]), "departPos": f"{pos:.2f}",
             "departSpeed": f"{v.speed:g}", "arrivalPos": f"{scn.scenario.exit_distance:g}",
             "insertionChecks": "none"}
    if v.exit_lane is not None:
        attrs["arrivalLane"] = str(LANE_INDEX[v.exit_lane])
    return v.depart, v.id, attrs, f"{p.approach}_in {p.exit_arm}_out"


def _paper_flow_entry(scn: Scenario, fv: dict, paths: dict[str, MovementPath]) -> RouteEntry:
    approach_len = next(p for p in paths.values() if p.approach == fv["approach"]).lane_starts[1]  # [m]
    pos = 0.0 if fv["distance"] is None else max(0.0, approach_len - fv["distance"])  # [m]
    attrs = {"id": fv["id"], "type": fv.get("driver", "av"), "depart": f"{fv['depart']:.2f}",
             "departLane": str(LANE_INDEX[fv["lane"]]), "departPos": f"{pos:.2f}",
             "departSpeed": "max", "arrivalPos": f"{scn.scenario.exit_distance:g}"}
    return fv["depart"], fv["id"], attrs, f"{fv['approach']}_in {exit_arm(fv['approach'], fv['movement'])}_out"


def _placed_entry(v: VehicleSpec) -> RouteEntry:
    """A hand-placed vehicle on a ``[network] file`` net: where it is put, as given (no insertion checks)."""
    attrs = {"id": v.id, "type": v.driver, "depart": f"{v.depart:g}", "departLane": str(v.depart_lane),
             "departPos": f"{v.depart_pos:.2f}", "departSpeed": f"{v.speed:g}", "insertionChecks": "none"}
    return v.depart, v.id, attrs, " ".join(v.route)


def _flow_entry(fv: dict) -> RouteEntry:
    """A flow vehicle on a ``[network] file`` net: SUMO inserts it at the start of its route's first
    edge ("base") unless the flow gives a position."""
    pos = "base" if fv["depart_pos"] is None else f"{fv['depart_pos']:.2f}"
    attrs = {"id": fv["id"], "type": fv.get("driver", "av"), "depart": f"{fv['depart']:.2f}", "departLane": fv["depart_lane"],
             "departPos": pos, "departSpeed": fv["speed"]}
    return fv["depart"], fv["id"], attrs, " ".join(fv["route"])


def route_files(scn: Scenario, user_routes: tuple[str, ...] | None = None) -> list[str]:
    """The route files SUMO loads for a run of ``scn``: the run's own (ROUTE_FILE, relative to the
    run folder), then the user's ``[network] routes`` files in their order (absolute;
    ``user_routes`` instead if given: their windowed copies), if any. When a [[vehicle]] or
    [[flow]] names a vType of the user's files, those come first: SUMO must read the vType before
    the first vehicle of it."""
    if not scn.network.routes:
        return [ROUTE_FILE]
    theirs_files = list(user_routes or scn.network.routes)
    theirs = {vt.id for vt in scn.vtypes if vt.from_routes}
    if any(spec.vtype in theirs for spec in (*scn.vehicles, *scn.flows)):
        return [*theirs_files, ROUTE_FILE]
    return [ROUTE_FILE, *theirs_files]


def run_output_options(folder: Path, ssm: bool = True, window: float | None = None) -> list[str]:
    """SUMO command-line options that write the run's own outputs into ``folder`` (absolute paths);
    without ``ssm`` (``[scenario] ssm = false``: no SSM device) no SSM file; SUMO's warnings and
    errors go to SUMO_LOG_FILE there; with ``window`` [s] (the run's length) SUMO's queue output
    aggregated over it (95th percentile and maximum per edge) and every vehicle's emissions device.

    Options on the command line override the config's, so the run's outputs land where they always
    did while the exported config keeps pointing at ``replay/``.
    """
    folder = Path(folder).resolve()
    outputs = [arg for option, name in SUMO_OUTPUT_FILES.items() if ssm or option != "device.ssm.file"
               for arg in (f"--{option}", str(folder / name))]
    log = ["--no-warnings", "false", "--error-log", str(folder / SUMO_LOG_FILE)]
    if window is None:
        return [*outputs, *log]
    measures = ["--queue-output", str(folder / QUEUES_FILE), "--queue-output.aggregation", f"{window:g}",
                "--queue-output.percentile", "95", "--device.emissions.probability", "1"]
    return [*outputs, *log, *measures]


def write_sumocfg(path: Path, net_file: str, scn: Scenario, user_routes: tuple[str, ...] | None = None,
                  additional: tuple[str, ...] = ()) -> None:
    """A config with every option of the run, its SUMO outputs going to ``replay/`` beside it.

    What it replays: ``sumo-gui -c scenario.sumocfg`` runs the same net, routes, step length, seed and
    SUMO options as the run, but with SUMO's own driver model and right of way; it does NOT run the
    game controller (or any other controller of this package), so the vehicles' motion differs
    from the run's trajectories. Its tripinfo, SSM and collision outputs go to ``replay/`` (made
    here, with a README), never over the run's own files. To watch the controller itself, use
    ``intersection-cosim run SCENARIO --gui``. ``user_routes`` replace the user's route files
    (their windowed copies); ``additional`` are the run's own additional files, after the user's.
    """
    replay = Path(path).parent / REPLAY_DIR
    replay.mkdir(exist_ok=True)
    (replay / "README.txt").write_text(REPLAY_README)
    s = scn.scenario
    adds = (*scn.network.additional, *additional)  # the user's, then the run's own (loaded last: in force)
    root = ET.Element("configuration")
    sections = {
        "input": {"net-file": net_file, "route-files": ",".join(route_files(scn, user_routes)),
                  **({"additional-files": ",".join(adds)} if adds else {}), **dict(scn.network.sumocfg_loading)},
        "time": {"begin": f"{s.begin or 0.0:g}", "end": f"{(s.begin or 0.0) + s.duration + s.drain:g}",
                 "step-length": f"{s.step_length:g}"},
        "processing": {"collision.check-junctions": "true", "collision.action": "warn",
                       "collision.mingap-factor": "0", "time-to-teleport": "-1",
                       "default.speeddev": "0"},
        "random_number": {"seed": str(s.seed)},
        "output": {"tripinfo-output": _replay("tripinfo-output"), "tripinfo-output.write-unfinished": "true",
                   "collision-output": _replay("collision-output")},
        "ssm_device": {"device.ssm.probability": "1", "device.ssm.measures": "TTC DRAC PET",
                       "device.ssm.thresholds": SSM_RECORD_THRESHOLDS, "device.ssm.range": f"{SSM_RANGE:g}",
                       "device.ssm.file": _replay("device.ssm.file"), "device.ssm.trajectories": "false"}
        if s.ssm else {},
        "report": {"no-warnings": "true", "no-step-log": "true", "duration-log.disable": "true"},
    }
    for section, options in sections.items():
        if not options:
            continue
        sec = ET.SubElement(root, section)
        for key, value in options.items():
            ET.SubElement(sec, key, value=value)
    _write(root, path)


def _replay(option: str) -> str:
    return f"{REPLAY_DIR}/{SUMO_OUTPUT_FILES[option]}"
