"""What a rule of the safety filter is: a name, a kind, and one function that reads the step's
context and writes into its working state.

A rule module's docstring is the rule's documentation, and the docs' rules table is generated from
it (:func:`describe`): a first line ``name: invariant`` (one or two sentences), then the fields
``Trigger:``, ``Action:``, ``Setting:`` and ``Test:``, each a paragraph of its own.
"""

from __future__ import annotations

import inspect
import re
import sys
from dataclasses import dataclass
from typing import Callable

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.step import FilterStep

SAFETY = "safety"  # what must never happen: a collision, an entry into a full box, a person run over
LIVENESS = "liveness"  # what keeps the junction from locking while the safety rules hold
FIELDS = ("Trigger", "Action", "Setting", "Test")


@dataclass(frozen=True)
class Rule:
    """One named rule; ``run(ctx, step)`` applies it to one step."""

    name: str
    kind: str  # SAFETY or LIVENESS
    run: Callable[[StepContext, FilterStep], None]
    each_look: bool = False  # run in each of the filter's two looks at the crossings (else once, before them)

    def describe(self) -> dict[str, str]:
        """The rule's row of the docs' table, from its module's docstring: name, kind, invariant,
        trigger, action, setting, test."""
        return describe(self)


def describe(rule: Rule) -> dict[str, str]:
    """See :meth:`Rule.describe`."""
    doc = inspect.getdoc(sys.modules[rule.run.__module__]) or ""
    head, _, rest = doc.partition("\n\n")
    name, _, invariant = head.partition(":")
    if name.strip() != rule.name:
        raise ValueError(f"the docstring of {rule.run.__module__} does not start with '{rule.name}:'")
    row = {"name": rule.name, "kind": rule.kind, "invariant": " ".join(invariant.split())}
    for key in FIELDS:
        found = re.search(rf"^{key}:(.*?)(?=^\w+:|\Z)", rest, flags=re.S | re.M)
        row[key.lower()] = " ".join(found.group(1).split()) if found else ""
    return row
