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
