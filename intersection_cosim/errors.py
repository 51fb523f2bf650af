"""User-facing input errors.

Every problem with user input (a scenario file, a command-line option, an output folder) is raised
as :class:`InputError`. The CLI turns it into one line on stderr and exit status 2, with no
traceback; nothing is written to disk before input has been validated.
"""

from __future__ import annotations


class InputError(Exception):
    """Bad user input, reported as ``<source>: <field> = <value>: <problem>``."""

    def __init__(self, source: str, field: str, value: object, problem: str):
        self.source = str(source)
        self.field = field
        self.value = value
        self.problem = problem
        super().__init__(self.one_line())

    def one_line(self) -> str:
        value = repr(self.value) if not isinstance(self.value, str) else repr(self.value)
        text = f"{self.source}: {self.field} = {value}: {self.problem}"
        return " ".join(text.split())  # never more than one line


class RouteRefusal(Exception):
    """SUMO stopped a running simulation because it could not route a vehicle or person it was to
    insert (e.g. "No connection found between edge 'a' and edge 'b' for person 'p.0'"): a route the
    input asks for does not exist on the net. ``time`` [s] is the simulation time it happened."""

    def __init__(self, time: float, message: str):
        self.time = float(time)
        self.message = " ".join(str(message).split())
        super().__init__(f"at t = {self.time:.2f} s: {self.message}")
