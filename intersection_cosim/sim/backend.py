"""Which module drives SUMO (libsumo in-process, or TraCI to a sumo-gui) and how it is started."""

from __future__ import annotations

import contextlib
import io
import subprocess
from dataclasses import dataclass
from types import ModuleType

import libsumo


def sumo_version() -> str:
    return libsumo.getVersion()[1]


@dataclass(frozen=True)
class SumoBackend:
    """Which module drives SUMO and which SUMO program it runs.

    ``module`` has libsumo's API (libsumo itself, or traci, which mirrors it over a socket);
    ``binary`` is the program traci starts (libsumo runs in-process and only reads the options).
    """

    module: ModuleType
    binary: str = "sumo"
    options: tuple[str, ...] = ()  # extra options for this program only (e.g. sumo-gui's --start)

    def start(self, args: list[str]) -> None:
        cmd = [self.binary, *args, *self.options]
        if self.module is libsumo:
            libsumo.start(cmd)
            return
        with contextlib.redirect_stdout(io.StringIO()):  # traci prints "Retrying" while the GUI opens
            self.module.start(cmd, stdout=subprocess.DEVNULL)


LIBSUMO = SumoBackend(libsumo)  # headless, in this process: every run but ``run --gui``


def traci_backend(binary: str, options: tuple[str, ...] = ()) -> SumoBackend:
    """A backend that starts ``binary`` (e.g. sumo-gui) and drives it through TraCI."""
    import traci

    return SumoBackend(traci, binary, tuple(options))


