"""Live view of a run in sumo-gui: the controller's decisions drawn onto the running simulation.

``run --gui`` drives sumo-gui through TraCI (:func:`~intersection_cosim.sim.sumo.traci_backend`)
instead of libsumo; the closed loop is the same. Each control step :meth:`GuiView.show` gets the
World the controller saw and the Decisions it returned, and

- colours every commanded vehicle by its kappa (blue cautious -> red aggressive, see
  :mod:`intersection_cosim.colors`) and every vehicle SUMO drives itself grey;
- rings the vehicles that play a game this step (amber) and joins each game's pair with a line;
- writes the step's decision as the vehicle's parameter ``cosim.decision``, shown as text on the
  vehicle (id, kappa, speed, commanded acceleration, game partners) and in its parameter dialog.

It only draws: nothing it does changes the simulation.
"""

from __future__ import annotations

import math
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import sumolib

from intersection_cosim.colors import GAME, UNCONTROLLED, kappa_color
from intersection_cosim.control.base import Decisions, World
from intersection_cosim.errors import InputError
from intersection_cosim.sim.sumo import SumoBackend, traci_backend

VIEW = "View #0"  # sumo-gui's first (only) view
TEXT_PARAM = "cosim.decision"  # vehicle parameter holding the decision text
LINK_PREFIX = "cosim.game:"  # polygon id prefix of the lines joining a game's pair
LINK_WIDTH = 0.4  # [m] width of those lines
RING_SIZE = 5.0  # [m] diameter of the ring around a vehicle in a game
TEXT_SIZE = 60  # [px] size of the decision text (constant on screen)


@dataclass(frozen=True)
class GuiSettings:
    """How ``run --gui`` shows a run."""

    delay_ms: float = 50.0  # [ms] sumo-gui's pause per SUMO step: 50 ~ real time at 0.05 s steps; 0: no pause
    zoom: float = 350.0  # [%] sumo-gui's zoom: 350 shows ~90 m around the junction in a 900 px view
    centre: tuple[float, float] = (0.0, 0.0)  # [m] view centre in the net (paper) frame: the junction
    window: tuple[int, int] = (1000, 900)  # [px] sumo-gui's window width, height
    screenshot: str | None = None  # [-] PNG written when the run reaches ``screenshot_at`` (None: none)
    screenshot_at: float = 0.0  # [s] simulation time of the screenshot
    screenshot_size: tuple[int, int] = (800, 800)  # [px] width, height of the screenshot


def check_display() -> None:
    """Raise :class:`InputError` when sumo-gui would find no X display to open its window on."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise InputError("--gui", "DISPLAY", "", "no display to open sumo-gui on (set DISPLAY, or run under xvfb-run)")


def view_settings_xml() -> str:
    """sumo-gui view settings: vehicles in their TraCI colour with the decision text shown on them."""
    return f"""<viewsettings>
    <scheme name="intersection-cosim">
        <vehicles vehicleMode="0" vehicleQuality="2" showBlinker="1" vehicleName_show="0"
                  vehicleTextParam="{TEXT_PARAM}" vehicleText_show="1" vehicleText_size="{TEXT_SIZE}"
                  vehicleText_color="black" vehicleText_bgColor="255,255,255,190" vehicleText_constantSize="1"/>
    </scheme>
</viewsettings>
"""


class GuiView:
    """One sumo-gui window showing one run; :meth:`close` removes its temporary settings file."""

    def __init__(self, settings: GuiSettings, vehicle_length: float):
        check_display()
        self.settings = settings
        self.vehicle_length = vehicle_length  # [m] to draw from the vehicle's centre, not its front
        self._dir = Path(tempfile.mkdtemp(prefix="intersection-cosim-gui-"))
        (self._dir / "view.xml").write_text(view_settings_xml())
        self._api: ModuleType | None = None
        self._links: set[str] = set()
        self._ringed: set[str] = set()
        self._shot_pending = settings.screenshot is not None

    def backend(self) -> SumoBackend:
        """TraCI to sumo-gui, started running, paused ``delay_ms`` per step, quitting at the end."""
        s = self.settings
        return traci_backend(sumolib.checkBinary("sumo-gui"),
                             ("--start", "--quit-on-end", "--delay", f"{s.delay_ms:g}",
                              "--window-size", f"{s.window[0]},{s.window[1]}",
                              "--gui-settings-file", str(self._dir / "view.xml")))

    def attach(self, api: ModuleType) -> None:
        """Point the view at the junction once sumo-gui runs (``api``: the traci module)."""
        self._api = api
        api.gui.setOffset(VIEW, *self.settings.centre)
        api.gui.setZoom(VIEW, self.settings.zoom)

    def show(self, world: World, decisions: Decisions) -> None:
        """Draw this control step's decisions; take the screenshot once its time has come."""
        partners: dict[str, list[str]] = {}
        for a, b in sorted({tuple(sorted(p)) for p in decisions.pairs}):
            partners.setdefault(a, []).append(b)
            partners.setdefault(b, []).append(a)
        for i, vid in enumerate(world.ids):
            self._decorate(vid, world, i, decisions.accel.get(vid), partners.get(vid, []))
        self._ring(set(partners) & set(world.ids))
        self._link(world, partners)
        if self._shot_pending and world.time >= self.settings.screenshot_at - 1e-9:
            w, h = self.settings.screenshot_size
            self._api.gui.screenshot(VIEW, str(Path(self.settings.screenshot).resolve()), w, h)
            self._shot_pending = False  # sumo-gui writes it when it draws the next step

    def close(self) -> None:
        shutil.rmtree(self._dir, ignore_errors=True)

    # --- drawing ---------------------------------------------------------------------------
    def _decorate(self, vid: str, world: World, i: int, accel: float | None, partners: list[str]) -> None:
        """Colour and decision text of one vehicle (``accel`` [m/s^2]; None: SUMO drives it)."""
        veh = self._api.vehicle
        kappa = float(world.kappa[i])
        veh.setColor(vid, (*(kappa_color(kappa) if accel is not None else UNCONTROLLED), 255))
        lines = [f"{vid}  k={kappa:.2f}  {world.v[i]:.1f} m/s"]
        lines.append(f"a_cmd={accel:+.2f} m/s2" if accel is not None else "SUMO drives")
        if partners:
            lines.append("game: " + ", ".join(partners))
        veh.setParameter(vid, TEXT_PARAM, "\n".join(lines))

    def _ring(self, in_game: set[str]) -> None:
        """Rings (sumo-gui highlights, which follow the vehicle) around the vehicles in a game."""
        for vid in sorted(in_game - self._ringed):
            self._api.vehicle.highlight(vid, (*GAME, 255), RING_SIZE)
        gone = self._ringed - in_game
        if gone:
            for pid in self._api.polygon.getIDList():
                if any(pid.startswith(f"{vid}_hl") for vid in gone):
                    self._api.polygon.remove(pid)
        self._ringed = in_game

    def _link(self, world: World, partners: dict[str, list[str]]) -> None:
        """One line per game, between the two vehicles' centres, redrawn every control step."""
        index = {vid: i for i, vid in enumerate(world.ids)}
        wanted = {}
        for a, others in partners.items():
            for b in others:
                if a < b and a in index and b in index:
                    wanted[f"{LINK_PREFIX}{a}-{b}"] = [self._centre(world, index[a]), self._centre(world, index[b])]
        poly = self._api.polygon
        for pid in self._links - set(wanted):
            poly.remove(pid)
        for pid, shape in wanted.items():
            if pid in self._links:
                poly.setShape(pid, shape)
            else:
                poly.add(pid, shape, (*GAME, 255), fill=False, layer=100, lineWidth=LINK_WIDTH)
        self._links = set(wanted)

    def _centre(self, world: World, i: int) -> tuple[float, float]:
        """[m] the vehicle's centre: its front bumper moved back half a length along its heading."""
        h = float(world.heading[i])
        half = self.vehicle_length / 2
        return float(world.x[i]) - half * math.cos(h), float(world.y[i]) - half * math.sin(h)
