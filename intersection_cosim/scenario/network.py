"""The ``[network]`` table -> :class:`NetworkSettings`: which SUMO net, junctions and route file.

Paths are relative to the scenario file; ``$VARS`` and ``~`` are expanded, and ``$SUMO_HOME``
falls back to the eclipse-sumo package's SUMO_HOME when the variable is unset. The net is read
once with sumolib (cached by path and modification time); a user route file is checked by
letting SUMO load it for one second of simulated time. Nothing is written anywhere.
"""

from __future__ import annotations

import difflib
import functools
import math
import os
import re
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import sumolib

from intersection_cosim.errors import InputError
from intersection_cosim.network.junction_net import junction_table, load_movements
from intersection_cosim.network.xml_files import xml_root
from intersection_cosim.scenario.model import DESIRED_SPEEDS, PAPER_JUNCTION, SIGNALS, NetworkSettings
from intersection_cosim.scenario.sumocfg import SumoConfig, read_sumocfg

NETWORK_KEYS = ("sumocfg", "file", "junctions", "signals", "control_range", "desired_speed", "routes",
                "additional")
ROUTE_CHECK_TIMEOUT = 30.0  # [s] wall time SUMO may take to load a user route file
VAR = re.compile(r"\$(\w+)|\$\{(\w+)\}")


def sumo_home() -> str:
    """``$SUMO_HOME`` if it names a SUMO installation (it has ``tools/``), else the eclipse-sumo
    package's SUMO_HOME. (Importing libsumo sets the variable to its data-only folder, which has
    no nets or tools: a scenario must not resolve against that.)"""
    env = os.environ.get("SUMO_HOME")
    if env and os.path.isdir(os.path.join(env, "tools")):
        return env
    import sumo

    return str(sumo.SUMO_HOME)


def sumo_binary() -> str:
    """The ``sumo`` binary of the eclipse-sumo package (the one libsumo belongs to)."""
    import sumo

    return os.path.join(str(sumo.SUMO_HOME), "bin", "sumo")


def resolve_path(src: str, field: str, value: Any, base: Path) -> str:
    """``value`` with ``~`` and ``$VARS`` expanded, made absolute against ``base`` (not checked to exist)."""
    if not isinstance(value, str) or not value.strip():
        raise InputError(src, field, value, "must be a non-empty string (a file path)")

    def expand(match: re.Match) -> str:
        name = match.group(1) or match.group(2)
        if name == "SUMO_HOME":
            return sumo_home()
        if name not in os.environ:
            raise InputError(src, field, value, f"${name} is not set")
        return os.environ[name]

    text = os.path.expanduser(VAR.sub(expand, value))
    return str((base / text).resolve())


@functools.lru_cache(maxsize=8)
def _read_net_cached(path: str, mtime_ns: int, size: int) -> sumolib.net.Net:
    return sumolib.net.readNet(path)


def read_net(path: str) -> sumolib.net.Net:
    """The sumolib net of ``path`` (no internal lanes), read once per file version."""
    st = os.stat(path)
    return _read_net_cached(path, st.st_mtime_ns, st.st_size)


def _net(src: str, value: Any, path: str) -> sumolib.net.Net:
    field = "network.file"
    if not os.path.exists(path):
        raise InputError(src, field, value, f"no such file ({path})")
    if not os.path.isfile(path) or not os.access(path, os.R_OK):
        raise InputError(src, field, value, f"cannot be read ({path})")
    try:
        net = read_net(path)
    except Exception as exc:  # lxml / sax parse errors, bad attributes
        raise InputError(src, field, value, f"is not a SUMO net ({type(exc).__name__}: {exc})") from None
    if not net.getEdges():
        raise InputError(src, field, value, "is not a SUMO net (it has no edges)")
    return net


def nearest(name: str, known: list[str], n: int = 3) -> str:
    """``name``'s nearest ids among ``known``, for a message ("nearest: 'a', 'b'"; a few ids if none is near)."""
    close = difflib.get_close_matches(name, known, n=n, cutoff=0.5)
    if close:
        return "nearest: " + ", ".join(repr(c) for c in close)
    return "the net has " + ", ".join(repr(c) for c in sorted(known)[:n]) + (", ..." if len(known) > n else "")


def _all_junctions(src: str, net_file: str) -> tuple[str, ...]:
    """``junctions = "all"``: every junction ``intersection-cosim junctions`` lists as manageable."""
    table = junction_table(net_file)
    ids = tuple(str(j) for j in table.loc[table["manageable"], "id"])
    if not ids:
        raise InputError(src, "network.junctions", "all", "the net has no manageable junction")
    return ids


def _junctions(src: str, value: Any, net: sumolib.net.Net) -> tuple[str, ...]:
    field = "network.junctions"
    if not isinstance(value, list) or not value or not all(isinstance(j, str) and j for j in value):
        raise InputError(src, field, value, 'must be "all" or a non-empty list of junction ids, like ["0"]')
    if len(set(value)) != len(value):
        raise InputError(src, field, value, "lists a junction twice")
    known = [node.getID() for node in net.getNodes() if node.getType() != "dead_end"]
    for jid in value:
        if not net.hasNode(jid):
            raise InputError(src, field, jid, f"is not a junction of the net ({nearest(jid, known)})")
    return tuple(value)


def _signals(src: str, value: Any) -> str:
    if value not in SIGNALS:
        raise InputError(src, "network.signals", value, f"must be one of {', '.join(repr(s) for s in SIGNALS)}")
    return value


def _desired_speed(src: str, value: Any) -> str:
    if value not in DESIRED_SPEEDS:
        raise InputError(src, "network.desired_speed", value,
                         f"must be one of {', '.join(repr(s) for s in DESIRED_SPEEDS)}")
    return value


def _control_range(src: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(src, "network.control_range", value, "must be a finite number [m]")
    if value <= 0:
        raise InputError(src, "network.control_range", value, "must be > 0 [m]")
    return float(value)


def route_file_ids(path: str) -> tuple[set[str], set[str]]:
    """The vType ids and the vehicle / trip / flow ids a route file defines (top level)."""
    root = xml_root(path)
    types = {el.get("id") for el in root if el.tag == "vType"}
    demand = {el.get("id") for el in root if el.tag in ("vehicle", "trip", "flow", "person", "personFlow")}
    return types, demand


def route_file_persons(path: str) -> int:
    """How many top-level pedestrians (``person`` and ``personFlow`` elements) a route file has."""
    return sum(el.tag in ("person", "personFlow") for el in xml_root(path))


def _routes(src: str, files: tuple[tuple[Any, str], ...], net_file: str, additional: tuple[str, ...] = (),
            loading: tuple[tuple[str, str], ...] = ()) -> tuple[str, ...]:
    """The route files ``files`` ((as given, absolute path) each), checked one by one and then
    loaded by SUMO together (a later file may use a vType of an earlier one), with the
    ``additional`` files (they may define the vTypes) and the config's ``loading`` options."""
    field = "network.routes"
    for value, path in files:
        if not os.path.isfile(path):
            raise InputError(src, field, value, f"no such file ({path})")
        try:
            root = xml_root(path)
        except (ET.ParseError, OSError) as exc:
            raise InputError(src, field, value, f"is not SUMO routes XML ({exc})") from None
        if root.tag != "routes":
            raise InputError(src, field, value, f"is not SUMO routes XML (its root is <{root.tag}>, not <routes>)")
    paths = tuple(path for _, path in files)
    refusal = sumo_refusal(net_file, paths, additional, loading)
    if refusal is not None:
        value = files[0][0] if len(files) == 1 else [v for v, _ in files]
        raise InputError(src, field, value, f"SUMO refuses it: {refusal}")
    return paths


def sumo_refusal(net_file: str, routes: tuple[str, ...], additional: tuple[str, ...] = (),
                 loading: tuple[tuple[str, str], ...] = ()) -> str | None:
    """SUMO's first "Error:" line loading the route files ``routes`` (with the ``additional``
    files and the ``loading`` options (name, value)) on ``net_file`` for 1 s (None: it accepts
    them); cached per version of the files."""
    stamps = tuple(os.stat(f).st_mtime_ns for f in (net_file, *routes, *additional))
    return _sumo_refusal(net_file, routes, additional, loading, stamps)


@functools.lru_cache(maxsize=8)
def _sumo_refusal(net_file: str, routes: tuple[str, ...], additional: tuple[str, ...],
                  loading: tuple[tuple[str, str], ...], stamps: tuple[int, ...]) -> str | None:
    """:func:`sumo_refusal`, cached per file versions (``stamps``): a sweep loads one scenario many
    times."""
    extra = [a for name, value in loading for a in (f"--{name}", value)]
    if additional:
        extra += ["--additional-files", ",".join(additional)]
    args = [sumo_binary(), "--net-file", net_file, "--route-files", ",".join(routes), *extra, "--begin", "0", "--end", "1",
            "--no-step-log", "true", "--no-warnings", "true", "--duration-log.disable", "true"]
    try:
        proc = subprocess.run(args, capture_output=True, text=True, timeout=ROUTE_CHECK_TIMEOUT,
                              env={**os.environ, "SUMO_HOME": sumo_home()})  # SUMO_HOME: XML schema checks
    except subprocess.TimeoutExpired:
        return None  # SUMO took long but has not refused them; the run will tell
    if proc.returncode == 0:
        return None
    lines = [ln for ln in (proc.stderr + proc.stdout).splitlines() if ln.startswith("Error:")]
    return lines[0] if lines else f"SUMO exit status {proc.returncode}"


def network_settings(src: str, table: Any, base: Path) -> NetworkSettings:
    """Validate the ``[network]`` table; ``base`` is the folder relative paths start from."""
    if table is None:
        return NetworkSettings()
    if not isinstance(table, dict):
        raise InputError(src, "network", table, "must be a table")
    for key in table:
        if key not in NETWORK_KEYS:
            raise InputError(src, f"network.{key}", table[key], f"unknown key (known: {', '.join(NETWORK_KEYS)})")
    cfg = None
    if "sumocfg" in table:
        cfg = read_sumocfg(src, table["sumocfg"], resolve_path(src, "network.sumocfg", table["sumocfg"], base))
    if "file" not in table and cfg is None:
        return _generated(src, table)
    net_value, net_file = _net_file(src, table, cfg, base)
    net = _net(src, net_value, net_file)
    if "junctions" not in table:
        raise InputError(src, "network.junctions", None, "is required with network.file (the ids to manage)")
    files = _route_files(src, table, cfg, base)
    additional = _additional(src, table, cfg, base)
    loading = () if cfg is None else cfg.loading
    routes = _routes(src, files, net_file, additional, loading) if files else ()
    junctions = _all_junctions(src, net_file) if table["junctions"] == "all" else _junctions(src, table["junctions"], net)
    settings = NetworkSettings(file=net_file, junctions=junctions,
                               signals=_signals(src, table.get("signals", "off")),
                               control_range=_control_range(src, table.get("control_range", 100.0)), routes=routes,
                               desired_speed=_desired_speed(src, table.get("desired_speed", NetworkSettings.desired_speed)),
                               sumocfg=None if cfg is None else cfg.path,
                               additional=additional, sumocfg_loading=loading,
                               sumocfg_begin=None if cfg is None else cfg.begin,
                               sumocfg_end=None if cfg is None else cfg.end)
    _check_manageable(src, settings)
    return settings


def _net_file(src: str, table: dict, cfg: SumoConfig | None, base: Path) -> tuple[Any, str]:
    """(as given, absolute path) of the net: ``file`` if the table has it, else the sumocfg's net-file."""
    if "file" in table:
        return table["file"], resolve_path(src, "network.file", table["file"], base)
    if cfg.net is None:
        raise InputError(src, "network.sumocfg", cfg.path, "names no net-file (give network.file)")
    return cfg.net, cfg.net


def _route_files(src: str, table: dict, cfg: SumoConfig | None, base: Path) -> tuple[tuple[Any, str], ...]:
    """(as given, absolute path) of each route file, in SUMO's order: ``routes`` (a path or a list
    of paths) if the table has it, else the sumocfg's route files (none: neither gives one)."""
    if "routes" not in table:
        return () if cfg is None else tuple((path, path) for path in cfg.routes)
    value = table["routes"]
    items = value if isinstance(value, list) else [value]
    if not items or not all(isinstance(v, str) and v for v in items):
        raise InputError(src, "network.routes", value, "must be a file path or a non-empty list of file paths")
    return tuple((v, resolve_path(src, "network.routes", v, base)) for v in items)


def _additional(src: str, table: dict, cfg: SumoConfig | None, base: Path) -> tuple[str, ...]:
    """The additional files: ``additional`` (a list of paths) if the table has it, else the sumocfg's."""
    if "additional" not in table:
        files = () if cfg is None else cfg.additional
    else:
        value = table["additional"]
        if not isinstance(value, list):
            raise InputError(src, "network.additional", value, "must be a list of file paths")
        files = tuple(resolve_path(src, "network.additional", v, base) for v in value)
    for path in files:
        if not os.path.isfile(path):
            raise InputError(src, "network.additional", path, "no such file")
    return files


def _check_manageable(src: str, settings: NetworkSettings) -> None:
    """The junctions' movements load (a dead end, a rail crossing or a junction without drivable
    connections is refused), reported against the scenario file; the movements stay cached."""
    try:
        load_movements(settings.file, settings.junctions, settings.control_range)
    except InputError as exc:
        raise InputError(src, exc.field, exc.value, exc.problem) from None


def _generated(src: str, table: dict) -> NetworkSettings:
    """A ``[network]`` table without ``file``: the generated net; the rest must be absent or default."""
    default = NetworkSettings()
    if "junctions" in table and table["junctions"] != [PAPER_JUNCTION]:
        raise InputError(src, "network.junctions", table["junctions"],
                         f'needs network.file (the generated net manages its centre, ["{PAPER_JUNCTION}"])')
    if "signals" in table and _signals(src, table["signals"]) != default.signals:
        raise InputError(src, "network.signals", table["signals"], "needs network.file")
    if "control_range" in table and _control_range(src, table["control_range"]) != default.control_range:
        raise InputError(src, "network.control_range", table["control_range"], "needs network.file")
    if "desired_speed" in table and _desired_speed(src, table["desired_speed"]) != default.desired_speed:
        raise InputError(src, "network.desired_speed", table["desired_speed"], "needs network.file or network.sumocfg")
    for key in ("routes", "additional"):
        if key in table:
            raise InputError(src, f"network.{key}", table[key], "needs network.file or network.sumocfg")
    return default


def net_of(settings: NetworkSettings) -> sumolib.net.Net | None:
    """The sumolib net of a ``[network] file`` (None on the generated net)."""
    return None if settings.file is None else read_net(settings.file)
