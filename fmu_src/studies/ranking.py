"""A study's candidates ranked: the feasible ones best first, the others by how near they come, as one table.

Motor sizing (:class:`grubler.studies.sizing.SizingStudy`) and cylinder sizing
(:class:`grubler.studies.cylinder_sizing.CylinderStudy`) rank their candidates
the same way and write the same table; :class:`RankedStudy` is that, once.  A
study gives ``assessments`` (each with ``feasible``, ``failures``, ``min_margin``
and ``summary()``), ``ranked`` (the feasible ones, best first) and, as a class
attribute, ``summary_units`` (each table column's unit).

Examples
--------
>>> from dataclasses import dataclass
>>> @dataclass
... class Fit:
...     feasible: bool
...     failures: list
...     min_margin: float
...     def summary(self):
...         return {"margin": self.min_margin}
>>> @dataclass
... class Toy(RankedStudy):
...     assessments: list
...     summary_units = {"margin": "1"}
...     @property
...     def ranked(self):
...         return [a for a in self.assessments if a.feasible]
>>> Toy([Fit(False, ["a", "b"], 0.2), Fit(True, [], 1.5), Fit(False, ["a"], 0.5)]).table()
[{'rank': 1, 'margin': 1.5}, {'rank': 'rejected', 'margin': 0.5}, {'rank': 'rejected', 'margin': 0.2}]
"""

from __future__ import annotations

from grubler.limits import open_output


class RankedStudy:
    """The table of a study that ranks candidates (see the module)."""

    summary_units: dict = {}

    @property
    def rejected(self) -> list:
        """The candidates that break a limit: fewest broken limits first, then the nearest to fitting."""
        return sorted((a for a in self.assessments if not a.feasible),
                      key=lambda a: (len(a.failures), -a.min_margin))

    def table(self) -> list[dict]:
        """One row per candidate: the ranked ones (rank 1, 2, ...), then the rejected ones with their reasons."""
        return ([{"rank": k + 1, **a.summary()} for k, a in enumerate(self.ranked)]
                + [{"rank": "rejected", **a.summary()} for a in self.rejected])

    def write_csv(self, path) -> None:
        """:meth:`table` as CSV, each heading with its unit (``peak_motor_speed [rpm]``, ``bore [mm]``)."""
        import csv

        from grubler.records import column_heading

        rows = self.table()
        cols = list(dict.fromkeys(c for r in rows for c in r))
        with open_output(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([column_heading(c, self.summary_units.get(c, "")) for c in cols])
            for r in rows:
                w.writerow([repr(v) if isinstance(v, float) else v for v in (r.get(c, "") for c in cols)])


__all__ = ["RankedStudy"]
