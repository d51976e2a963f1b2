"""Run CSVs, from ``grubler simulate`` or ``grubler cosim``, in one vocabulary.

A simulate CSV names the mechanism's columns plainly (``theta2``, ``Fx``); a
cosim CSV prefixes every signal with its component (``mechanism.theta2``,
``motor.current``).  The report and the animation read both through
:func:`read_run_csv`, which strips the mechanism's prefix and names the drive
effort, current and voltage the way a simulate CSV would.
"""

from __future__ import annotations

import csv
import io

import numpy as np

from .errors import GrublerError, InputError
from .limits import MAX_MAGNITUDE, MAX_TABLE_BYTES, PATH_CHARS, brief, read_text
from .model import Mechanism


def mechanism_prefix(names: list[str]) -> str | None:
    """The component whose columns are a mechanism's (``None`` for a simulate CSV).

    Examples
    --------
    >>> mechanism_prefix(["t", "motor.current", "arm.theta2", "arm.closure_error"])
    'arm'
    >>> mechanism_prefix(["t", "theta2", "closure_error"]) is None
    True
    """
    if "closure_error" in names or "theta2" in names:
        return None
    prefixes = [n.rsplit(".", 1)[0] for n in names if n.endswith(".closure_error") or n.endswith(".drive_angle")]
    prefixes = list(dict.fromkeys(prefixes))
    if len(prefixes) > 1:
        raise GrublerError(f"the CSV holds several mechanisms ({', '.join(prefixes)}); report one at a time")
    return prefixes[0] if prefixes else None


def run_columns(raw: dict[str, np.ndarray], model: Mechanism | None = None) -> dict[str, np.ndarray]:
    """A run's columns in simulate vocabulary (see the module's notes)."""
    names = list(raw)
    if "t" not in raw:
        raise GrublerError("not a run CSV (no 't' column)")
    prefix = mechanism_prefix(names)
    if prefix is None:
        return dict(raw)
    cols = {"t": raw["t"]}
    head = prefix + "."
    for n, v in raw.items():
        if n.startswith(head):
            cols[n[len(head):]] = v
    for n, v in raw.items():  # the first current and voltage of another component
        leaf = n.rsplit(".", 1)[-1]
        if not n.startswith(head) and leaf in ("current", "voltage") and leaf not in cols:
            cols[leaf] = v
    if "motor_torque" in cols:
        cols["tau_drive"] = cols["motor_torque"]
        if "drive_speed" in cols:
            cols["P_drive"] = cols["tau_drive"] * cols["drive_speed"]
    if "KE" in cols and "PE" in cols and "E" not in cols:
        cols["E"] = cols["KE"] + cols["PE"]
    return cols


def read_table(path: str, field: str = "csv") -> dict[str, np.ndarray]:
    """A numeric CSV table: a header of distinct names, then rows of finite numbers.

    Every row must have one value per column, every value be a finite number
    within :data:`grubler.limits.MAX_MAGNITUDE`, and ``t`` (when present) must
    increase.  A refusal names the file, the line and the column.
    """
    text = read_text(path, field, MAX_TABLE_BYTES)
    where = brief(str(path), PATH_CHARS)
    try:
        lines = [row for row in csv.reader(io.StringIO(text)) if row and any(c.strip() for c in row)]
    except csv.Error as exc:
        raise InputError(field, f"{where}: not a CSV table ({exc})") from None
    if not lines:
        raise InputError(field, f"{where}: empty, not a run CSV (no header)")
    header = [h.strip() for h in lines[0]]
    if any(not h for h in header):
        raise InputError(field, f"{where}: the header has an empty column name")
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise InputError(field, f"{where}: column {brief(dup[0])} appears twice in the header")
    if len(lines) < 2:
        raise InputError(field, f"{where}: a header and no rows")
    for i, row in enumerate(lines[1:], start=2):
        if len(row) != len(header):
            raise InputError(field, f"{where}: row {i} has {len(row)} values for {len(header)} columns")
    body = lines[1:]
    try:
        data = np.array(body, dtype=float)
    except ValueError:
        for i, row in enumerate(body, start=2):
            for name, cell in zip(header, row):
                try:
                    float(cell)
                except ValueError:
                    raise InputError(field, f"{where}: row {i}, column {brief(name)}: not a number: "
                                            f"{brief(cell)}") from None
        raise
    bad = ~np.isfinite(data) | (np.abs(np.nan_to_num(data)) > MAX_MAGNITUDE)
    if bad.any():
        i, j = map(int, np.argwhere(bad)[0])
        raise InputError(field, f"{where}: row {i + 2}, column {brief(header[j])}: {data[i, j]:g} is not a finite "
                                f"number within +-{MAX_MAGNITUDE:g}")
    cols = {h: data[:, j].copy() for j, h in enumerate(header)}
    if "t" in cols and len(cols["t"]) > 1 and np.any(np.diff(cols["t"]) <= 0):
        i = int(np.argmax(np.diff(cols["t"]) <= 0))
        raise InputError(field, f"{where}: column 't' must increase, row {i + 3} does not")
    return cols


def read_run_csv(path: str, model: Mechanism | None = None, field: str = "csv") -> dict[str, np.ndarray]:
    """Read a simulate or cosim CSV (see :func:`read_table`) into simulate-vocabulary columns."""
    raw = read_table(path, field)
    try:
        cols = run_columns(raw, model)
    except GrublerError as exc:
        raise InputError(field, f"{brief(str(path), PATH_CHARS)}: {exc}") from None
    if model is not None:
        missing = [n for n in model.coordinate_names if n not in cols]
        if missing:
            raise InputError(field, f"{brief(str(path), PATH_CHARS)}: missing columns {', '.join(missing)} "
                                    "(is it a run of this scene?)")
    return cols


def coordinates(cols: dict[str, np.ndarray], model: Mechanism) -> np.ndarray:
    """Real joint coordinates z at each row, from the absolute ones."""
    q = np.column_stack([cols[n] for n in model.coordinate_names])
    return np.array([model.z_from_q(row) for row in q])


__all__ = ["read_run_csv", "read_table", "run_columns", "mechanism_prefix", "coordinates"]
