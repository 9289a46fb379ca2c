"""An evaluation beside the published numbers (``examples/evaluate.py --compare NAME``): which protocol and sources, what
may be shown anyway, and the lines of :func:`vigen.results.compare` in each unit the sources publish.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vigen.results import SOURCES, PartialData, ProtocolMismatch, RecipeMismatch, StandInRows, compare, load, published
from vigen.results.compare import VALUE_UNITS


@dataclass(frozen=True)
class Comparison:
    """``--compare``: the protocol, its sources, and what may be shown beside them anyway (each line saying so).

    Examples:
        >>> comparison = Comparison.named("sgqn")
        >>> comparison.protocol, comparison.sources
        ('dmcgb', ['sgqn'])
        >>> "sgqn" in Comparison.named("dmcgb").sources
        True
    """

    name: str
    protocol: str
    sources: list[str]
    allow_budget_mismatch: bool = False
    allow_stand_ins: bool = False
    allow_partial_data: bool = False
    allow_recipe_mismatch: bool = False

    @classmethod
    def named(cls, name: str, **allowed: bool) -> Comparison:
        """A protocol names every source published under it; a source, its own protocol. ``allowed``: the ``allow_*`` fields."""
        from vigen.protocols import PROTOCOLS

        if name in PROTOCOLS:
            return cls(name, name, [source for source in SOURCES if any(row.protocol == name for row in load(source))], **allowed)
        return cls(name, load(name)[0].protocol, [name], **allowed)

    def lines(self, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """:func:`vigen.results.compare` on the return and, where the rows and the sources have one, the success rate
        (Adroit publishes success only).

        Raises:
            ProtocolMismatch, StandInRows, PartialData, RecipeMismatch: the runs or their data cannot stand beside the
                published numbers (each names every difference).
            ValueError: the sources publish nothing comparable for these rows.
        """
        lines, nothing = [], []
        for value in ("return", "success"):
            if all(value in row for row in rows) and published(source=self.sources, unit=VALUE_UNITS[value]):
                try:
                    lines += compare(rows, source=self.sources, protocol=self.protocol, value=value,
                                     allow_budget_mismatch=self.allow_budget_mismatch, allow_stand_ins=self.allow_stand_ins,
                                     allow_partial_data=self.allow_partial_data,
                                     allow_recipe_mismatch=self.allow_recipe_mismatch)
                except (ProtocolMismatch, StandInRows, PartialData, RecipeMismatch):  # the run or its data, not the unit: stop
                    raise
                except ValueError as error:  # nothing published in this unit for these rows
                    nothing.append(str(error))
        if not lines:
            raise ValueError(" ".join(nothing) or f"{', '.join(self.sources)} publish nothing comparable.")
        return lines
