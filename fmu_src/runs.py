"""Run CSVs, from ``grubler simulate`` or ``grubler cosim``, in one vocabulary.

A simulate CSV names the mechanism's columns plainly (``theta2``, ``Fx``); a
cosim CSV prefixes every signal with its component (``mechanism.theta2``,
``motor.current``).  The report and the animation read both through
:func:`read_run_csv`, which strips the mechanism's prefix and names the drive
effort, current and voltage the way a simulate CSV would.
"""

from __future__ import annotations

import numpy as np

from .errors import GrublerError
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


def read_run_csv(path: str, model: Mechanism | None = None) -> dict[str, np.ndarray]:
    """Read a simulate or cosim CSV into simulate-vocabulary columns."""
    data = np.genfromtxt(path, delimiter=",", names=True, deletechars="")
    if data.dtype.names is None:
        raise GrublerError(f"{path}: not a run CSV (no header)")
    raw = {n: np.atleast_1d(data[n]) for n in data.dtype.names}
    try:
        cols = run_columns(raw, model)
    except GrublerError as exc:
        raise GrublerError(f"{path}: {exc}") from None
    if model is not None:
        missing = [n for n in model.coordinate_names if n not in cols]
        if missing:
            raise GrublerError(f"{path}: missing columns {', '.join(missing)} (is it a run of this scene?)")
    return cols


def coordinates(cols: dict[str, np.ndarray], model: Mechanism) -> np.ndarray:
    """Real joint coordinates z at each row, from the absolute ones."""
    q = np.column_stack([cols[n] for n in model.coordinate_names])
    return np.array([model.z_from_q(row) for row in q])


__all__ = ["read_run_csv", "run_columns", "mechanism_prefix", "coordinates"]
