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
import math
import re

import numpy as np

from grubler.records import column_heading, split_heading
from grubler.errors import GrublerError, InputError
from grubler.limits import MAX_MAGNITUDE, MAX_TABLE_BYTES, PATH_CHARS, brief, read_text
from grubler.mechanism.model import Mechanism


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
    """A run's columns in simulate vocabulary (see the module's notes).

    Examples
    --------
    >>> import numpy as np
    >>> raw = {"t": np.array([0.0, 0.1]), "arm.theta2": np.array([0.0, 0.2]), "arm.closure_error": np.zeros(2),
    ...        "arm.motor_torque": np.array([0.5, 0.6]), "motor.current": np.array([1.0, 1.5])}
    >>> cols = run_columns(raw)                 # a cosim record, named as a simulate CSV names it
    >>> sorted(cols)
    ['closure_error', 'current', 'motor_torque', 't', 'tau_drive', 'theta2']
    >>> run_columns({"theta2": np.zeros(2)})
    Traceback (most recent call last):
    ...
    grubler.errors.GrublerError: not a run CSV (no 't' column)
    """
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
    for n, v in raw.items():  # the first current, voltage, position setpoint and cylinder of another component
        leaf = n.rsplit(".", 1)[-1]
        leaf = "cylinder_force" if leaf == "force" else leaf
        if not n.startswith(head) and leaf in ("current", "voltage", "setpoint", "pressure_a", "pressure_b",
                                               "supply_pressure", "cylinder_force") and leaf not in cols:
            cols[leaf] = v
    if model is not None and len(model.actuators) == 1 and "cylinder_force" in cols:
        # the mechanism's actuator force is its input, which a record keeps as the cylinder's output
        cols.setdefault(f"{model.actuator_names[0]}_force", cols["cylinder_force"])
    if "motor_torque" in cols:
        cols["tau_drive"] = cols["motor_torque"]
        if "drive_speed" in cols:
            cols["P_drive"] = cols["tau_drive"] * cols["drive_speed"]
    if "KE" in cols and "PE" in cols and "E" not in cols:
        cols["E"] = cols["KE"] + cols["PE"]
    return cols


class Table(dict):
    """A CSV table's columns by name (a dict), with ``units``: each column's unit, '' where the file gave none.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> _ = (d / "co.csv").write_text("t [s],arm.theta2 [rad],arm.closure_error [m],arm.motor_torque [N.m],"
    ...                               "motor.current [A]\\n0,0,0,0.5,1.0\\n0.1,0.2,0,0.6,1.5\\n")
    >>> table = read_table(d / "co.csv")        # a Table: a dict of columns, with their units
    >>> list(table)[:3], table.units["motor.current"]
    (['t', 'arm.theta2', 'arm.closure_error'], 'A')
    >>> tmp.cleanup()
    """

    units: dict[str, str]


def read_table(path: str, field: str = "csv") -> Table:
    """A numeric CSV table: a header of distinct names, then rows of finite numbers.

    A heading may carry its column's unit in brackets (``motor.current [A]``,
    see :func:`column_heading`): the column is named without it and the unit
    kept in the table's ``units``.  Every row must have one value per column,
    every value be a finite number within :data:`grubler.limits.MAX_MAGNITUDE`,
    and ``t`` (when present) must increase.  A refusal names the file, the line
    and the column.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> _ = (d / "co.csv").write_text("t [s],arm.theta2 [rad],arm.closure_error [m],arm.motor_torque [N.m],"
    ...                               "motor.current [A]\\n0,0,0,0.5,1.0\\n0.1,0.2,0,0.6,1.5\\n")
    >>> read_table(d / "co.csv")["motor.current"]
    array([1. , 1.5])
    >>> _ = (d / "bad.csv").write_text("t,x\\n0,1\\n0.1,nan\\n")
    >>> read_table(d / "bad.csv")             # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    grubler.errors.InputError: csv: '.../bad.csv': row 3, column 'x': nan is not a finite number within +-1e+12
    >>> tmp.cleanup()
    """
    text = read_text(path, field, MAX_TABLE_BYTES)
    where = brief(str(path), PATH_CHARS)
    try:
        lines = [row for row in csv.reader(io.StringIO(text)) if row and any(c.strip() for c in row)]
    except csv.Error as exc:
        raise InputError(field, f"{where}: not a CSV table ({exc})") from None
    if not lines:
        raise InputError(field, f"{where}: empty, not a run CSV (no header)")
    header, units = zip(*(split_heading(h) for h in lines[0]))
    header = list(header)
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
    cols = Table((h, data[:, j].copy()) for j, h in enumerate(header))
    cols.units = dict(zip(header, units))
    if "t" in cols and len(cols["t"]) > 1 and np.any(np.diff(cols["t"]) <= 0):
        i = int(np.argmax(np.diff(cols["t"]) <= 0))
        raise InputError(field, f"{where}: column 't' must increase, row {i + 3} does not")
    return cols


def read_run(path: str, model: Mechanism | None = None, field: str = "csv"):
    """Read a simulate or cosim CSV (see :func:`read_table`): its columns as named, and in simulate vocabulary.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> _ = (d / "co.csv").write_text("t [s],arm.theta2 [rad],arm.closure_error [m],arm.motor_torque [N.m],"
    ...                               "motor.current [A]\\n0,0,0,0.5,1.0\\n0.1,0.2,0,0.6,1.5\\n")
    >>> raw, cols = read_run(d / "co.csv")       # as the file names them, and in simulate vocabulary
    >>> "motor.current" in raw, cols["current"].tolist(), cols["tau_drive"].tolist()
    (True, [1.0, 1.5], [0.5, 0.6])
    >>> tmp.cleanup()
    """
    raw = read_table(path, field)
    try:
        cols = run_columns(raw, model)
    except GrublerError as exc:
        raise InputError(field, f"{brief(str(path), PATH_CHARS)}: {exc}") from None
    if model is not None:
        missing = [n for n in model.coordinate_names if n not in cols]
        if missing:
            raise InputError("--scene", f"{model.name or 'the scene'} does not fit {brief(str(path), PATH_CHARS)}: "
                                        f"it has no columns {', '.join(missing)}, which a run of this scene has")
    return raw, cols


def read_run_csv(path: str, model: Mechanism | None = None, field: str = "csv") -> dict[str, np.ndarray]:
    """Read a simulate or cosim CSV (see :func:`read_table`) into simulate-vocabulary columns.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> _ = (d / "co.csv").write_text("t [s],arm.theta2 [rad],arm.closure_error [m],arm.motor_torque [N.m],"
    ...                               "motor.current [A]\\n0,0,0,0.5,1.0\\n0.1,0.2,0,0.6,1.5\\n")
    >>> sorted(read_run_csv(d / "co.csv"))
    ['closure_error', 'current', 'motor_torque', 't', 'tau_drive', 'theta2']
    >>> tmp.cleanup()
    """
    return read_run(path, model, field)[1]


def column_unit(name: str, names) -> str:
    """The unit of a run column: the file's (a :class:`Table`'s), else the library's for a mechanism's, else ''.

    Examples
    --------
    >>> column_unit("arm.theta2_d", ["t", "arm.theta2", "arm.closure_error"])
    'rad/s'
    >>> column_unit("motor.current", ["t", "arm.theta2", "arm.closure_error"])
    ''
    """
    from grubler.mechanism.simulate import unit_of

    if getattr(names, "units", {}).get(name):
        return names.units[name]
    prefix = mechanism_prefix(list(names))
    leaf = name[len(prefix) + 1:] if prefix and name.startswith(prefix + ".") else (None if prefix else name)
    if leaf is None:
        return ""
    try:
        return unit_of(leaf)
    except (KeyError, ValueError):
        return ""


def signal_names(spec: str, available, field: str = "--signals", limit: int | None = None) -> list[str]:
    """The comma-separated column names of ``spec``, each one of ``available`` (else refused, with a suggestion).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> _ = (d / "co.csv").write_text("t [s],arm.theta2 [rad],arm.closure_error [m],arm.motor_torque [N.m],"
    ...                               "motor.current [A]\\n0,0,0,0.5,1.0\\n0.1,0.2,0,0.6,1.5\\n")
    >>> raw, cols = read_run(d / "co.csv")
    >>> signal_names("motor.current, arm.theta2", raw)
    ['motor.current', 'arm.theta2']
    >>> signal_names("motor.curent", raw)
    Traceback (most recent call last):
    ...
    grubler.errors.InputError: --signals: no column 'motor.curent' in the run; did you mean 'motor.current'?
    >>> tmp.cleanup()
    """
    from grubler.limits import did_you_mean

    names = [n.strip() for n in spec.split(",") if n.strip()]
    if not names:
        raise InputError(field, "expected column names separated by commas, e.g. theta2,tau_drive")
    if limit is not None and len(names) > limit:
        raise InputError(field, f"at most {limit} signals fit under the mechanism, got {len(names)}")
    choices = [c for c in available if c != "t"]
    for name in names:
        if name not in choices:
            raise InputError(field, f"no column {brief(name)} in the run{did_you_mean(name, choices)}")
    return names


def select_signals(spec: str, columns: dict[str, np.ndarray], field: str = "--signals", limit: int | None = None):
    """``(label with unit, values)`` of the comma-separated column names in ``spec`` (see :func:`signal_names`).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> tmp = tempfile.TemporaryDirectory(); d = pathlib.Path(tmp.name)
    >>> _ = (d / "co.csv").write_text("t [s],arm.theta2 [rad],arm.closure_error [m],arm.motor_torque [N.m],"
    ...                               "motor.current [A]\\n0,0,0,0.5,1.0\\n0.1,0.2,0,0.6,1.5\\n")
    >>> raw, cols = read_run(d / "co.csv")
    >>> [(label, values.tolist()) for label, values in select_signals("motor.current", raw)]   # labelled with the unit
    [('motor.current [A]', [1.0, 1.5])]
    >>> tmp.cleanup()
    """
    out = []
    for name in signal_names(spec, list(columns), field, limit):
        unit = column_unit(name, columns)
        out.append((f"{name} [{unit}]" if unit else name, columns[name]))
    return out


def coordinates(cols: dict[str, np.ndarray], model: Mechanism) -> np.ndarray:
    """Real joint coordinates z at each row, from the absolute ones (one matrix product).

    ``model.z_from_q`` is affine (differences of absolute angles, the slides as
    they are), so it is its value at q = 0 plus a matrix read off its columns.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import grubler
    >>> res = grubler.simulate("thesis-fourbar", t_end=0.5)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     res.to_csv(pathlib.Path(d) / "run.csv")
    ...     cols = read_run_csv(pathlib.Path(d) / "run.csv")
    >>> z = coordinates(cols, res.model)        # the real joint coordinates, what the animation draws
    >>> z.shape, bool(abs(z - res.z).max() < 1e-9)
    ((51, 3), True)
    """
    q = np.column_stack([cols[n] for n in model.coordinate_names])
    nq = q.shape[1]
    z0 = model.z_from_q(np.zeros(nq))
    M = np.column_stack([model.z_from_q(e) - z0 for e in np.eye(nq)])
    return z0 + q @ M.T


FIT_TOL = 1e-4  # m per m of the longest link, or rad: how far a run's recorded loop may be open under its scene


def check_fits(model: Mechanism, cols: dict[str, np.ndarray], path: str, field: str = "--scene") -> None:
    """Refuse a scene whose geometry does not close the loop the CSV recorded.

    The recorded coordinates are put into the scene's closure equations at up to
    200 rows spread over the run; the largest violation must be within
    :data:`FIT_TOL` (times the longest link for a distance) or ten times the
    closure error the run itself recorded (a penalty run's), whichever is larger.
    A slider-crank scene given for a four-bar run leaves its loop open by
    decimetres; the run's own scene closes it to rounding.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import grubler
    >>> with tempfile.TemporaryDirectory() as d:
    ...     grubler.simulate("thesis-fourbar", t_end=0.5).to_csv(pathlib.Path(d) / "run.csv")
    ...     cols = read_run_csv(pathlib.Path(d) / "run.csv")
    >>> check_fits(grubler.load_scene("thesis-fourbar").mechanism, cols, "run.csv")   # its own scene: fits
    >>> check_fits(grubler.load_scene("slider-crank").mechanism, cols, "run.csv")     # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    grubler.errors.InputError: --scene: slider-crank does not fit 'run.csv': its geometry leaves the recorded loop (closure[0]) open by 1.05 rad at t = 0 s, ...
    """
    from grubler.mechanism.assembly import constraint

    if not model.closures:
        return
    zs = coordinates(cols, model)
    t = cols["t"]
    rows = np.unique(np.linspace(0, len(t) - 1, min(len(t), 200)).astype(int))
    recorded = float(np.max(np.abs(cols["closure_error"]))) if "closure_error" in cols else 0.0
    scale = max(abs(lk.a) for lk in model.links) or 1.0
    worst = (0.0, "", 0, 0.0)  # (violation / tolerance, text, row, ...)
    for i in rows:
        phi, _ = constraint(model, zs[i])
        for j, cl in enumerate(model.closures):
            for r in (2 * j, 2 * j + 1):
                angle = cl.kind != "revolute" and r == 2 * j + 1  # a slide closure's second row is its angle
                v = abs(math.remainder(phi[r], 2 * math.pi)) if angle else abs(phi[r])
                tol = max(FIT_TOL if angle else FIT_TOL * scale, 10 * recorded)
                if v / tol > worst[0]:
                    worst = (v / tol, f"{v:.3g} {'rad' if angle else 'm'}", int(i), tol, j, angle)
    if worst[0] > 1.0:
        _, text, i, tol, j, angle = worst
        raise InputError(field, f"{model.name or 'the scene'} does not fit {brief(str(path), PATH_CHARS)}: its "
                                f"geometry leaves the recorded loop (closure[{j}]) open by {text} at t = {t[i]:.4g} s, "
                                f"more than the {tol:.2g} {'rad' if angle else 'm'} a run of it would; name the scene "
                                "the run came from")


__all__ = ["Table", "check_fits", "column_heading", "read_run", "read_run_csv", "read_table", "split_heading",
           "run_columns", "mechanism_prefix", "coordinates",
           "column_unit", "select_signals", "signal_names"]
