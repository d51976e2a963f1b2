"""How every CSV table grubler writes heads its columns: the name, then the unit in brackets.

One header line keeps a table readable by any CSV reader (numpy, pandas, a
spreadsheet) and says what each number is in. The simulation, the
co-simulation, sizing and sweeps write with :func:`column_heading`;
:func:`grubler.views.runs.read_table` reads back with :func:`split_heading`.
"""

from __future__ import annotations

import re

def column_heading(name: str, unit: str = "") -> str:
    """A CSV column's heading: its name, then its unit in brackets when it has one.

    The one header line keeps the table readable by any CSV reader (numpy,
    pandas, a spreadsheet) and says what each number is in; :func:`read_table`
    takes the unit back off.

    Examples
    --------
    >>> column_heading("motor.current", "A"), column_heading("rank")
    ('motor.current [A]', 'rank')
    """
    return f"{name} [{unit}]" if unit else name


def split_heading(heading: str) -> tuple[str, str]:
    """A heading's name and unit (see :func:`column_heading`); '' for a heading without one.

    Examples
    --------
    >>> split_heading("mechanism.theta2 [rad]"), split_heading("theta2")
    (('mechanism.theta2', 'rad'), ('theta2', ''))
    """
    found = _HEADING.fullmatch(heading.strip())
    return (found.group(1).strip(), found.group(2).strip()) if found else (heading.strip(), "")


_HEADING = re.compile(r"(.*\S)\s+\[([^\[\]]*)\]")
