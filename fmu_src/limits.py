"""What outside input may ask of the program: numbers, files, sizes, archives, temporary folders.

Every command, the scene reader, the SSP reader and the run-CSV reader take what
comes from outside through this module, so that a bad value is refused in one
way everywhere: an :class:`~grubler.errors.InputError` naming the field (or the
option) and the reason, before anything large is allocated or written.

- numbers: :func:`number` (finite, within a range, a whole number when asked,
  and no larger in magnitude than :data:`MAX_MAGNITUDE`, beyond which the
  kernel's squares and products leave double precision);
- files: :func:`read_text` (a size cap, UTF-8, no binary), :func:`parse_toml`
  (nesting depth and huge integers), :func:`output_file` (checked before the
  run: a folder that exists, an extension the writer knows), :func:`open_output`
  (a write that fails names its file);
- sizes: :func:`check_size` (an estimate of what an output would take, refused
  with the size and the option that changes it);
- archives: :func:`extract_zip` (bounded total size, compression ratio and
  member count, checked while reading, not only from the declared sizes);
- temporary folders: :func:`temp_dir` registers each one so that
  :func:`remove_temp_dirs` (called by the CLI on every exit path, and at
  interpreter exit) leaves nothing behind.

Examples
--------
>>> number("2.5", "--t-end", low=0.0, low_open=True)
2.5
>>> try:
...     number(float("nan"), "link2.m")
... except InputError as exc:
...     print(exc)
link2.m: must be a finite number, got nan
>>> brief("x" * 1000, 20)
"'xxxxxxxx...xxxxxxxx' (1002 characters)"
"""

from __future__ import annotations

import atexit
import contextlib
import math
import os
import re
import shutil
import tempfile
import threading
import tomllib
import zipfile
import zlib
from pathlib import Path

from grubler.errors import InputError, LimitError, SceneError

# Largest magnitude a number from outside may have.  Lengths, masses, gains and
# torques are multiplied together in the equations of motion (m a^2 w^2 ...):
# past ~1e12 their products leave the range where a double keeps the digits the
# integrator's error test needs, and past ~1e154 their squares overflow.
MAX_MAGNITUDE = 1e12
# Output budget: what an array, table or file a command writes may take.  It can
# be raised for a big machine (GRUBLER_MAX_OUTPUT_BYTES, in bytes).
MAX_OUTPUT_BYTES = 2 * 1024**3
MAX_TEXT_BYTES = 16 * 1024**2  # a scene or an SSD: kilobytes in practice
MAX_TABLE_BYTES = 512 * 1024**2  # a run CSV
MAX_TOML_DEPTH = 32  # a scene nests three tables deep
# Archives (SSP, FMU): an FMU compresses 3 to 10 times; a zip bomb 1000 times.
ARCHIVE_MAX_BYTES = 2 * 1024**3
ARCHIVE_MAX_RATIO = 200.0
ARCHIVE_MAX_MEMBERS = 10_000
MAX_STEPS = 1e9  # rounds of a loop the input sets (communication steps): a day of FMU calls
MAX_POINTS = 1e6  # points of a sweep grid
MESSAGE_CHARS = 80  # what a message quotes of a value
PATH_CHARS = 240  # of a path (head and tail: its file name is kept)


def brief(value, limit: int = MESSAGE_CHARS) -> str:
    """``repr(value)``, cut to ``limit`` characters so that a message stays one readable line."""
    return clip(repr(value), limit)


def clip(text: str, limit: int = MESSAGE_CHARS) -> str:
    """``text`` itself, cut to ``limit`` characters (:func:`brief` without the quotes)."""
    text = str(text)
    if len(text) <= limit:
        return text
    half = max(limit // 2 - 1, 1)  # head and tail: a path's file name is at its end
    return f"{text[:half]}...{text[-half:]} ({len(text)} characters)"


def did_you_mean(word, choices) -> str:
    """"; did you mean 'x'?" for the closest of ``choices`` to a misspelt ``word``, else "".

    Examples
    --------
    >>> did_you_mean("thesis-forbar", ["thesis-fourbar", "oldham"])
    "; did you mean 'thesis-fourbar'?"
    >>> did_you_mean("zzz", ["thesis-fourbar"])
    ''
    """
    import difflib

    if not isinstance(word, str) or len(word) > PATH_CHARS:
        return ""
    close = difflib.get_close_matches(word, [str(c) for c in choices], n=1, cutoff=0.75)
    return f"; did you mean {close[0]!r}?" if close else ""


def number(value, field: str, *, low: float | None = None, high: float | None = None, low_open: bool = False,
           integer: bool = False, magnitude: float = MAX_MAGNITUDE, unit: str = "") -> float:
    """A finite number from outside (int, float or its text), or an InputError naming ``field``.

    Parameters
    ----------
    value : int, float or str
    field : str
        The field or option, as the user spells it.
    low, high : float, optional
        Inclusive bounds (``low`` exclusive with ``low_open``).
    integer : bool
        It must be a whole number (returned as ``int``).
    magnitude : float
        Largest absolute value accepted.
    unit : str
        The quantity's unit, written after the numbers of a bound's message.

    Examples
    --------
    >>> number("0.3", "--t-end", low=0.0, low_open=True, unit="s")
    0.3
    >>> try:
    ...     number("-1", "--t-end", low=0.0, low_open=True, unit="s")
    ... except ValueError as exc:
    ...     print(exc)
    --t-end: must be > 0 s, got -1 s
    """
    u = f" {unit}" if unit else ""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise InputError(field, f"must be a number, got {brief(value)}")
    if isinstance(value, str):
        text = value.strip()
        if len(text) > 64:
            raise InputError(field, f"is not a number: {brief(value)}")
        try:
            v = int(text) if integer and text.lstrip("+-").isdigit() else float(text)
        except ValueError:
            raise InputError(field, f"is not a number: {brief(value)}") from None
    else:
        v = value
    if isinstance(v, int) and abs(v) > magnitude:
        raise InputError(field, f"magnitude above {magnitude:g}{u} is outside the supported range, "
                                f"got {brief(v, 24)}{u}")
    v_f = float(v)
    if not math.isfinite(v_f):
        raise InputError(field, f"must be a finite number, got {brief(value)}")
    if abs(v_f) > magnitude:
        raise InputError(field, f"magnitude above {magnitude:g}{u} is outside the supported range, got {v_f:g}{u}")
    if low is not None and (v_f < low or (low_open and v_f == low)):
        raise InputError(field, f"must be {'>' if low_open else '>='} {low:g}{u}, got {v_f:g}{u}")
    if high is not None and v_f > high:
        raise InputError(field, f"must be <= {high:g}{u}, got {v_f:g}{u}")
    if integer:
        if v_f != int(v_f):
            raise InputError(field, f"must be a whole number, got {v_f:g}")
        return int(v_f)
    return v_f


# -- files ----------------------------------------------------------------------------------
def read_bytes(path: str | Path, field: str, max_bytes: int = MAX_TEXT_BYTES) -> bytes:
    """The bytes of a regular file no larger than ``max_bytes``."""
    p = Path(path)
    where = brief(str(p), PATH_CHARS)
    try:
        if not p.exists():
            raise InputError(field, f"{where}: no such file")
        if not p.is_file():
            raise InputError(field, f"{where}: not a regular file")
        size = p.stat().st_size
    except OSError as exc:  # a name too long for the file system, a folder we may not look into
        raise InputError(field, f"{where}: {exc.strerror or exc}") from None
    if size > max_bytes:
        raise LimitError(field, f"{where} is {_size(size)}, more than the {_size(max_bytes)} this reader accepts")
    try:
        with open(p, "rb") as fh:
            data = fh.read(max_bytes + 1)  # the file may have grown since stat()
    except OSError as exc:  # a file we may not read, or whose reading fails (/proc/self/mem)
        raise InputError(field, f"{where}: cannot be read ({exc.strerror or type(exc).__name__})") from None
    if len(data) > max_bytes:
        raise LimitError(field, f"{where} is more than the {_size(max_bytes)} this reader accepts")
    return data


def decode_text(data: bytes, field: str, where: str = "") -> str:
    """UTF-8 text, refusing binary data by name."""
    head = f"{where}: " if where else ""
    nul = data.find(b"\x00")
    if nul >= 0:
        raise InputError(field, f"{head}a binary file, not text (a NUL byte at offset {nul})")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(field, f"{head}not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})") \
            from None


def read_text(path: str | Path, field: str, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """A UTF-8 text file no larger than ``max_bytes``, or an InputError naming ``field``."""
    return decode_text(read_bytes(path, field, max_bytes), field, brief(str(path), PATH_CHARS))


def parse_toml(text: str, field: str) -> dict:
    """TOML text, with the nesting depth bounded (tomllib recurses) and huge integers refused."""
    depth = deepest = 0
    quote = None
    for ch in text:  # brackets outside strings: an upper bound of tomllib's recursion
        if quote:
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
        elif ch == "\n":
            depth = max(depth, 0)
    if deepest > MAX_TOML_DEPTH:
        raise InputError(field, f"not valid here: arrays or tables nested {deepest} deep "
                                f"(at most {MAX_TOML_DEPTH})")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(field, f"not valid TOML: {exc}") from None
    except (RecursionError, ValueError) as exc:  # ValueError: an integer of more than 4300 digits
        raise InputError(field, f"not valid here: {brief(str(exc), 120)}") from None


def _writable_formats() -> set[str]:
    from matplotlib.backend_bases import FigureCanvasBase

    return set(FigureCanvasBase.get_supported_filetypes())


def output_file(path: str, option: str, suffixes: tuple[str, ...] | str | None = None) -> Path:
    """Check, before the run, that ``path`` can be written: its folder exists, it is not a
    folder, and its extension is one of ``suffixes`` (``'figure'``: what matplotlib writes)."""
    p = Path(path)
    where = brief(str(path), PATH_CHARS)
    if not str(path) or p.name in ("", ".", "..") or "\x00" in str(path):
        raise InputError(option, f"{where} is not a file name")
    parent = p.parent if str(p.parent) else Path(".")
    try:
        if p.is_dir():
            raise InputError(option, f"{where} is a folder; give a file name")
        if not parent.is_dir():
            raise InputError(option, f"{where}: the folder {brief(str(parent), PATH_CHARS)} does not exist")
    except OSError as exc:  # a name too long for the file system, a folder we may not look into
        raise InputError(option, f"{where}: {exc.strerror or exc}") from None
    if suffixes is not None:
        allowed = sorted(_writable_formats()) if suffixes == "figure" else [s.lstrip(".") for s in suffixes]
        ext = p.suffix.lower().lstrip(".")
        if ext not in allowed:
            raise InputError(option, f"{where}: cannot write a {ext or 'file without extension'!r} file; "
                                     f"use one of {', '.join('.' + a for a in allowed)}")
    return p


@contextlib.contextmanager
def open_output(path, mode: str = "w", **kwargs):
    """``open(path, mode)`` for a file a command writes, whose every OSError names ``path``.

    A write or a close that fails (``/proc/version`` opens, then answers EIO)
    raises an OSError without a file name; this one carries ``path``, so the
    CLI can say which option and which file (:func:`grubler.cli.run`).
    """
    try:
        with open(path, mode, **kwargs) as fh:
            yield fh
    except OSError as exc:
        if exc.filename is None:
            exc.filename = os.fspath(path)
        raise


# -- sizes ----------------------------------------------------------------------------------
def _size(n: float) -> str:
    for unit in ("bytes", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.3g} {unit}" if unit != "bytes" else f"{int(n)} bytes"
        n /= 1000
    return f"{n:.3g} EB"


def check_size(count: float, bytes_each: float, what: str, option: str, budget: int | None = None) -> int:
    """Refuse an output of ``count`` items of ``bytes_each`` that would exceed the budget.

    Returns ``count`` as an int when it fits.  The message gives the estimate and
    the option that changes it.
    """
    if budget is None:  # the environment is input too: read through the same gate, when used
        raw = os.environ.get("GRUBLER_MAX_OUTPUT_BYTES")
        budget = MAX_OUTPUT_BYTES if raw is None else number(raw, "GRUBLER_MAX_OUTPUT_BYTES", low=1.0,
                                                               magnitude=math.inf)
    if not math.isfinite(count) or count * bytes_each > budget:
        total = count * bytes_each
        raise LimitError(option, f"{what} would take {_size(total) if math.isfinite(total) else 'unbounded memory'}"
                                 f" ({count:.3g} items), more than the {_size(budget)} budget; change it "
                                 "(or raise GRUBLER_MAX_OUTPUT_BYTES)")
    return int(count)


def check_count(count: float, limit: float, what: str, option: str) -> int:
    """Refuse a loop of ``count`` rounds, input-controlled, beyond ``limit``; else ``int(count)``."""
    if not (math.isfinite(count) and count <= limit):
        raise LimitError(option, f"{count:.3g} {what}, more than the {limit:.3g} this command allows; change it")
    return int(count)


# -- temporary folders ----------------------------------------------------------------------
_TEMP: list[Path] = []
_TEMP_LOCK = threading.Lock()


def temp_dir(prefix: str) -> Path:
    """A new temporary folder, removed by :func:`remove_temp_dirs` (or at interpreter exit)."""
    p = Path(tempfile.mkdtemp(prefix=prefix))
    with _TEMP_LOCK:
        _TEMP.append(p)
    return p


def remove_temp_dir(path: Path) -> None:
    """Remove one registered temporary folder now."""
    with _TEMP_LOCK:
        if path in _TEMP:
            _TEMP.remove(path)
    shutil.rmtree(path, ignore_errors=True)


def remove_temp_dirs() -> None:
    """Remove every temporary folder this process made (the CLI calls it on every exit)."""
    with _TEMP_LOCK:
        paths, _TEMP[:] = list(_TEMP), []
    for p in paths:
        shutil.rmtree(p, ignore_errors=True)


atexit.register(remove_temp_dirs)


# -- archives -------------------------------------------------------------------------------
def extract_zip(path: str | Path, dest: Path, field: str, max_bytes: int | None = None,
                max_ratio: float | None = None, max_members: int | None = None,
                where: str | None = None) -> Path:
    """Extract a zip archive into ``dest`` within bounds, counting the bytes actually inflated.

    Refuses (InputError naming ``field``) an archive that is not a zip, one with
    more than ``max_members`` members, more than ``max_bytes`` in total or a
    member inflating more than ``max_ratio`` times (past a 1 MB allowance, so
    small well-compressed text is fine); the bounds default to the module's.  Member names that would leave ``dest``
    are refused too.  On a refusal, what was extracted is removed.  ``where``
    names the archive in messages (default: its path).
    """
    max_bytes = ARCHIVE_MAX_BYTES if max_bytes is None else max_bytes
    max_ratio = ARCHIVE_MAX_RATIO if max_ratio is None else max_ratio
    max_members = ARCHIVE_MAX_MEMBERS if max_members is None else max_members
    name = where or brief(str(path), PATH_CHARS)
    try:
        zf = zipfile.ZipFile(path)
    except zipfile.BadZipFile:
        raise InputError(field, f"{name}: not a zip archive") from None
    except OSError as exc:
        raise InputError(field, f"{name}: cannot be read ({exc.strerror or exc})") from None
    dest = Path(dest)
    root = dest.resolve()
    total = 0
    try:
        with zf:
            infos = zf.infolist()
            if len(infos) > max_members:
                raise LimitError(field, f"{name}: {len(infos)} members, more than {max_members}")
            for info in infos:
                target = (dest / info.filename).resolve()
                if root != target and root not in target.parents:
                    raise InputError(field, f"{name}: member {brief(info.filename)} would be written outside "
                                            "the extraction folder")
                if info.is_dir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                allowance = max(info.compress_size * max_ratio, 1024**2)
                written = 0
                with zf.open(info) as src, open(target, "wb") as out:
                    while chunk := src.read(1 << 20):
                        written += len(chunk)
                        total += len(chunk)
                        if written > allowance:
                            raise LimitError(field, f"{name}: member {brief(info.filename)} inflates more than "
                                                    f"{max_ratio:g} times its compressed size (a zip bomb?)")
                        if total > max_bytes:
                            raise LimitError(field, f"{name}: more than {_size(max_bytes)} once extracted")
                        out.write(chunk)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, NotImplementedError, zlib.error) as exc:
        shutil.rmtree(dest, ignore_errors=True)
        raise InputError(field, f"{name}: a damaged or unsupported zip archive ({brief(str(exc), 100)})") from None
    except BaseException:
        shutil.rmtree(dest, ignore_errors=True)
        raise
    return dest


__all__ = ["number", "read_text", "read_bytes", "decode_text", "parse_toml", "output_file", "open_output",
           "check_size",
           "extract_zip", "clip", "temp_dir", "remove_temp_dir", "remove_temp_dirs", "brief", "MAX_MAGNITUDE",
           "MAX_OUTPUT_BYTES", "check_count"]


# -- angles --------------------------------------------------------------------------
_ANGLE = re.compile(
    r"^\s*(?P<num>[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?)\s*(?P<unit>deg|degrees?|rad|°)?\s*$"
)
_PI = re.compile(r"^\s*(?P<sign>[+-])?\s*(?P<k>(\d+(\.\d*)?|\.\d+))?\s*\*?\s*pi\s*(/\s*(?P<d>\d+(\.\d*)?))?\s*$")


def parse_angle_or_number(value, field: str) -> float:
    """A number, or a string such as '60 deg', '1.2 rad', 'pi/3', '-2*pi/3'.

    Whatever the spelling, the value goes through :func:`grubler.limits.number`:
    finite and no larger in magnitude than :data:`grubler.limits.MAX_MAGNITUDE`.
    """
    if isinstance(value, str) and len(value) <= 64:
        m = _ANGLE.match(value)
        p = _PI.match(value)
        if m:
            v = float(m["num"])
            if m["unit"] in ("deg", "degree", "degrees", "°"):
                v = math.radians(v)
        elif p:
            v = math.pi * float(p["k"] or 1.0) / float(p["d"] or 1.0)
            v = -v if p["sign"] == "-" else v
        else:
            raise SceneError(field, f"cannot read {brief(value)} as a number or an angle ('60 deg', 'pi/3')")
        value = v
    elif isinstance(value, str):
        raise SceneError(field, f"cannot read {brief(value)} as a number or an angle ('60 deg', 'pi/3')")
    try:
        return number(value, field)
    except InputError as exc:
        raise SceneError(exc.field, exc.reason) from None


def parse_number(value, field: str, unit: str = "") -> float:
    """A quantity that is neither an angle nor a length (a mass, a torque, a gain, a time): a number in its
    SI unit, or the text of one alone; an angle ('1 deg', 'pi/2') or any unit written after it is refused
    rather than read as so many kg or N m.  ``unit`` names the SI unit in the refusal.

    Examples
    --------
    >>> parse_number("2.5", "link2.m", "kg")
    2.5
    >>> try:
    ...     parse_number("1 deg", "link2.m", "kg")
    ... except SceneError as exc:
    ...     print(exc)
    link2.m: '1 deg' is not a plain number: write the value in kg as a number (2.5)
    """
    if isinstance(value, str):
        m = _ANGLE.match(value) if len(value) <= 64 else None
        if m is None or m["unit"] or _PI.match(value):
            raise SceneError(field, f"{brief(value.strip())} is not a plain number: write the value in "
                                    f"{unit or 'its SI unit'} as a number (2.5)")
    try:
        return number(value, field)
    except InputError as exc:
        raise SceneError(exc.field, exc.reason) from None


def parse_angle(value, field: str) -> float:
    """An angle, rad: a number is radians; text names its unit.

    Text reads '30 deg', '30°', '0.5 rad', 'pi/6' or '-2*pi/3'; bare text such as
    '30' is refused, since nothing tells whether it meant degrees.  The rule of
    every angle typed on the command line and of the API's angles given as text;
    a TOML number or a Python float is radians.

    Examples
    --------
    >>> parse_angle("30 deg", "--at") == math.radians(30)
    True
    >>> try:
    ...     parse_angle("30", "--at")
    ... except SceneError as exc:
    ...     print(exc)
    --at: '30' has no unit: write '30 deg' or '30 rad' (or a multiple of pi, 'pi/6')
    """
    if isinstance(value, str) and len(value) <= 64:
        m = _ANGLE.match(value)
        if m and not m["unit"]:
            raise SceneError(field, f"{brief(value.strip())} has no unit: write '{value.strip()} deg' or "
                                    f"'{value.strip()} rad' (or a multiple of pi, 'pi/6')")
    return parse_angle_or_number(value, field)


# -- lengths ---------------------------------------------------------------------------
# a length's units, in metres; an angle's words are told apart so that the refusal can say what was typed
_LENGTH_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}
_LENGTH = re.compile(r"^\s*(?P<num>[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?)\s*(?P<unit>[a-zA-Z°]+)?\s*$")
_LENGTH_HINT = "a length was expected: metres as a number (0.3) or text with a length unit ('0.3 m', '300 mm')"


def parse_length(value, field: str) -> float:
    """A length, m: a number is metres; text is a number with m, cm or mm ('0.3 m', '300 mm').

    An angle ('90 deg', 'pi/2') is refused rather than read as so many metres, as is
    any other unit; the value goes through :func:`grubler.limits.number` (finite,
    bounded).  The rule of every length of a scene, ``--set``, a sweep and the app.

    Examples
    --------
    >>> parse_length("300 mm", "link2.a")
    0.3
    >>> parse_length(0.25, "link2.a")
    0.25
    >>> try:
    ...     parse_length("90 deg", "link2.a")
    ... except SceneError as exc:
    ...     print(exc)
    link2.a: '90 deg' is an angle; a length was expected: metres as a number (0.3) or text with a length unit ('0.3 m', '300 mm')
    """
    if isinstance(value, str):
        m = _LENGTH.match(value) if len(value) <= 64 else None
        unit = m["unit"] if m else None
        if m is None or (unit is not None and unit not in _LENGTH_UNITS):
            shown = brief(value.strip())
            if _PI.match(value) or (m is not None and unit in ("deg", "degree", "degrees", "°", "rad")):
                raise SceneError(field, f"{shown} is an angle; {_LENGTH_HINT}")
            if m is not None:
                raise SceneError(field, f"{shown}: {brief(unit)} is not a length unit; {_LENGTH_HINT}")
            raise SceneError(field, f"cannot read {shown}; {_LENGTH_HINT}")
        try:
            # the number as typed is bounded first: '1e400 mm' is refused, not scaled to inf
            v = number(m["num"], field)
            return number(v * _LENGTH_UNITS[unit or "m"], field)
        except InputError as exc:
            raise SceneError(exc.field, exc.reason) from None
    try:
        return number(value, field)
    except InputError as exc:
        raise SceneError(exc.field, exc.reason) from None
