"""The fuzz suite's contract, its input generators and its hypothesis profiles.

The contract every generated input is held to (docs/reliability.md):

- the command exits 0 with finite output (no ``nan`` printed, every number in
  a CSV it wrote finite), or 2 with an error that names the field: its first
  line is ``grubler[ cmd]: error: FIELD: REASON``, no line is longer than 500
  characters, no traceback;
- nothing is written outside the paths the user named (the working folder is
  compared before and after);
- the temporary folder is empty afterwards (each run gets a private one).

Anything else (an exception out of :func:`grubler.cli.run`, another exit
status) fails the example, and hypothesis shrinks it to a small reproducer.

Profiles (``GRUBLER_FUZZ_PROFILE``): ``ci`` (the default: derandomized, a fixed
number of examples per class, what ``pytest`` runs) and ``long`` (random, 25
times the examples; ``python benchmarks/fuzz_long.py``).  With
``GRUBLER_FUZZ_REPORT=FILE`` the outcomes per class are written there as JSON at
exit; with ``GRUBLER_FUZZ_LOG=FILE`` every example's command line, exit status and
error line are appended there (JSON lines).  A new class (the FMU call sequences, for one) is a test that calls
:func:`check_cli` or records through :func:`record` under its own class name.
"""

from __future__ import annotations

import atexit
import contextlib
import io
import json
import math
import os
import re
import shutil
import tempfile
import warnings
import zipfile
from collections import defaultdict
from pathlib import Path

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from grubler import cli

PROFILE = os.environ.get("GRUBLER_FUZZ_PROFILE", "ci")
SCALE = {"ci": 1, "long": 25}[PROFILE]
settings.register_profile("ci", derandomize=True, deadline=None, database=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
settings.register_profile("long", derandomize=False, deadline=None, database=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
settings.load_profile(PROFILE)

# Hypothesis (since 6.131) also draws constants read from the source of every local module loaded in this process
# (hypothesis.internal.conjecture.providers._get_local_constants), so a derandomized example depended on which
# modules earlier tests had happened to import: test_fuzz_animate_csv drew a crashing CSV after eight other test
# files, never alone, and a fuzz verdict could flip on a change to any module. The CI profile draws from
# Hypothesis's own constants only: the same examples alone, in any selection and in any order. (A Hypothesis that
# renames this fails test_fuzz's test_what_is_drawn_does_not_depend_on_the_modules_earlier_tests_loaded, one named
# test, rather than every fuzz test at import; the long profile keeps them.)
if PROFILE == "ci":
    from hypothesis.internal.conjecture import providers as _providers

    if callable(getattr(_providers, "_get_local_constants", None)):
        _NO_LOCAL_CONSTANTS = _providers.Constants()
        _providers._get_local_constants = lambda: _NO_LOCAL_CONSTANTS


def examples(n: int) -> settings:
    """Settings for a class: ``n`` examples in the CI profile, ``n`` times the profile's scale otherwise."""
    return settings(max_examples=n * SCALE)


# -- outcomes per class ---------------------------------------------------------------------------
OUTCOMES: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))


def record(cls: str, outcome: str) -> None:
    OUTCOMES[cls]["tried"] += 1
    OUTCOMES[cls][outcome] += 1


def _write_outcomes() -> None:
    path = os.environ.get("GRUBLER_FUZZ_REPORT")
    if path and OUTCOMES:
        Path(path).write_text(json.dumps({k: dict(v) for k, v in OUTCOMES.items()}, indent=1, sort_keys=True))


atexit.register(_write_outcomes)

# -- the contract ---------------------------------------------------------------------------------
_ERROR = re.compile(r"^grubler(?: [a-z]+)?: error: (?:argument )?[^:\n]+: .+")
_NAN = re.compile(r"(?<![A-Za-z_])nan(?![A-Za-z_])", re.IGNORECASE)


def _files(root: Path) -> set[Path]:
    return {p.relative_to(root) for p in root.rglob("*") if p.is_file()}


def check_cli(cls: str, argv: list[str], inputs: dict[str, bytes], outputs: tuple[str, ...] = (),
              allow_inf: bool = False) -> int:
    """Run ``grubler ARGV`` in this process, in a fresh folder holding ``inputs``; check the contract.

    ``outputs`` are the file names the command was told to write (relative to
    the folder); a sweep's journal beside its table counts as named.
    ``allow_inf``: an infinite number in a written CSV is an answer (a sizing
    margin with nothing to exceed), not a failure.  Returns the exit status.
    """
    base = Path(tempfile.mkdtemp(prefix="grubler_fuzz_"))
    work, tmp = base / "work", base / "tmp"
    work.mkdir()
    tmp.mkdir()
    for name, data in inputs.items():
        (work / name).write_bytes(data)
    before = _files(work)
    old_cwd, old_tmp = os.getcwd(), tempfile.tempdir
    out, err = io.StringIO(), io.StringIO()
    try:
        os.chdir(work)
        tempfile.tempdir = str(tmp)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = cli.run(argv)
        new = _files(work) - before
        allowed = {Path(o) for o in outputs} | {Path(o + ".journal.jsonl") for o in outputs}
        stray = {p for p in new if p not in allowed and not re.fullmatch(r".*\.journal\.jsonl\.\d+", p.name)}
        assert not stray, f"{argv}: wrote files nobody named: {sorted(map(str, stray))}"
        left = list(tmp.iterdir())
        assert not left, f"{argv}: left in the temporary folder: {left}"
        text_err = err.getvalue()
        assert code in (0, 2), f"{argv}: exit {code}\n{text_err}"
        assert "Traceback" not in text_err, text_err
        if code == 2:
            lines = text_err.strip().splitlines()
            assert lines and _ERROR.match(lines[0]), f"{argv}: not an error naming a field: {text_err!r}"
            assert all(len(line) <= 500 for line in lines), f"{argv}: an error line too long"
            assert len(lines) <= 52, f"{argv}: {len(lines)} lines of error"
        else:
            assert not _NAN.search(out.getvalue()), f"{argv}: printed a nan:\n{out.getvalue()}"
            for p in new:
                if p.suffix == ".csv":
                    _assert_finite_csv(work / p, allow_inf)
    finally:
        os.chdir(old_cwd)
        tempfile.tempdir = old_tmp
        shutil.rmtree(base, ignore_errors=True)
    record(cls, "exit 0" if code == 0 else "exit 2")
    if os.environ.get("GRUBLER_FUZZ_LOG"):  # one line per example: what was run and what it got
        with open(os.environ["GRUBLER_FUZZ_LOG"], "a") as fh:
            fh.write(json.dumps({"class": cls, "argv": argv, "exit": code,
                                 "error": text_err.strip().splitlines()[:1]}) + "\n")
    return code


def _assert_finite_csv(path: Path, allow_inf: bool) -> None:
    for row in path.read_text().splitlines()[1:]:
        for cell in row.split(","):
            try:
                v = float(cell)
            except ValueError:
                continue  # text columns (a sweep's status, a sizing's motor name)
            assert not math.isnan(v), f"{path.name}: a nan in row {row!r}"
            assert allow_inf or math.isfinite(v), f"{path.name}: {cell!r} in row {row!r}"


# -- values a hostile user types ------------------------------------------------------------------
NASTY_TEXT = ["", " ", "nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e999", "0", "-0", "-1", "1e-320",
              "9" * 400, "0x10", "1_000", "abc", "60 deg", "pi/3", "-2*pi/3", "R", "P", "theta2", "\u00e9",
              "a=b", "../x", "\x00", "1,2", "tcp://x", "1:2:3"]


def number_text(small: bool = False) -> st.SearchStrategy[str]:
    """Option values: mostly numbers (small ones when ``small``), some of every nasty spelling."""
    finite = st.floats(-1e3, 1e3) if not small else st.floats(1e-3, 0.05)
    plausible = st.floats(0.01, 100.0) if not small else st.floats(1e-3, 0.05)
    return st.one_of(finite.map(repr), plausible.map(repr), plausible.map(lambda x: f"{x:.3g}"),
                     st.sampled_from(NASTY_TEXT),
                     st.floats(allow_nan=True, allow_infinity=True).map(repr),
                     st.integers(-10**30, 10**30).map(str), st.text(max_size=8))


def nasty_value() -> st.SearchStrategy:
    """A TOML value where a number (or a word) belongs."""
    return st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.floats(-10.0, 10.0),
        st.floats(0.01, 3.0),
        st.floats(0.01, 3.0),
        st.integers(-10**6, 10**6),
        st.integers().map(lambda k: k * 10**400),
        st.sampled_from(NASTY_TEXT),
        st.booleans(),
        st.lists(st.floats(-2, 2), max_size=3),
        st.dictionaries(st.sampled_from(["a", "m", "x"]), st.floats(-2, 2), max_size=2),
    )


# -- TOML written by hand (the standard library reads TOML but does not write it) ---------------
def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)  # nan, inf, -inf are TOML's spellings too
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def toml_text(data: dict) -> str:
    top = [f"{json.dumps(k)} = {toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    tables = [f"[{json.dumps(k)}]\n" + "\n".join(f"{json.dumps(kk)} = {toml_value(vv)}" for kk, vv in v.items())
              for k, v in data.items() if isinstance(v, dict)]
    return "\n".join(top) + "\n\n" + "\n\n".join(tables) + "\n"


# -- SSD text --------------------------------------------------------------------------------------
SSD_NS = ('xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
          'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
          'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"')


def xml_attr(v: str) -> str:
    return (v.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")
            .encode("utf-8", "surrogatepass").decode("utf-8", "replace"))


@st.composite
def ssd_text(draw) -> str:
    names = draw(st.lists(st.sampled_from(["mech", "motor", "pid", "2bad", "a b", ""]), min_size=0, max_size=3))
    comps = []
    for n in names:
        params = "".join(
            f'<ssv:Parameter name="{xml_attr(p)}"><ssv:{tag} value="{xml_attr(v)}"/></ssv:Parameter>'
            for p, tag, v in draw(st.lists(st.tuples(st.sampled_from(["link2.m", "gain", ""]),
                                                     st.sampled_from(["Real", "Integer", "Boolean", "String"]),
                                                     number_text()), max_size=2)))
        binding = ('<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues><ssv:ParameterSet '
                   f'version="1.0" name="p"><ssv:Parameters>{params}</ssv:Parameters></ssv:ParameterSet>'
                   '</ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>') if params else ""
        source = draw(st.sampled_from(["A.fmu", "resources/A.fmu", "missing.fmu", "", "/", "../../A.fmu"]))
        comps.append(f'<ssd:Component name="{xml_attr(n)}" source="{source}">{binding}</ssd:Component>')
    conns = "".join(
        f'<ssd:Connection startElement="{a}" startConnector="{b}" endElement="{c}" endConnector="{d}"/>'
        for a, b, c, d in draw(st.lists(st.tuples(*[st.sampled_from(["mech", "motor", "x", "theta2", ""])] * 4),
                                        max_size=2)))
    exp = draw(st.sampled_from(["", "<ssd:DefaultExperiment {}/>"]))
    if exp:
        exp = exp.format(" ".join(f'{k}="{xml_attr(draw(number_text()))}"'
                                  for k in draw(st.lists(st.sampled_from(["startTime", "stopTime"]), unique=True))))
    ann = ""
    if draw(st.booleans()):
        ann = ('<ssd:Annotations><ssc:Annotation type="org.grubler.cosim">'
               f'<Cosim step="{xml_attr(draw(number_text()))}" order="{xml_attr(draw(st.text(max_size=6)))}"/>'
               '</ssc:Annotation></ssd:Annotations>')
    text = (f'<?xml version="1.0" encoding="UTF-8"?><ssd:SystemStructureDescription {SSD_NS} version="1.0" '
            f'name="s"><ssd:System name="s"><ssd:Elements>{"".join(comps)}</ssd:Elements>'
            f'<ssd:Connections>{conns}</ssd:Connections></ssd:System>{exp}{ann}</ssd:SystemStructureDescription>')
    cut = draw(st.one_of(st.none(), st.integers(0, len(text))))  # sometimes truncated
    return text if cut is None else text[:cut]


@st.composite
def ssp_archive(draw) -> bytes:
    """A .ssp: a zip of an SSD and members (junk FMUs, bombs, escaping names), or not a zip at all."""
    if draw(st.integers(0, 9)) == 0:
        return draw(st.binary(max_size=200))
    buf = io.BytesIO()
    with warnings.catch_warnings(), zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        warnings.simplefilter("ignore", UserWarning)  # duplicate member names are part of the test
        if draw(st.integers(0, 4)):
            zf.writestr("SystemStructure.ssd", draw(ssd_text()))
        for kind in draw(st.lists(st.sampled_from(["fmu-junk", "fmu-zip", "bomb", "escape", "dir"]), max_size=3)):
            if kind == "fmu-junk":
                zf.writestr("resources/A.fmu", draw(st.binary(max_size=64)))
            elif kind == "fmu-zip":
                inner = io.BytesIO()
                with zipfile.ZipFile(inner, "w") as z2:
                    z2.writestr("modelDescription.xml", draw(st.sampled_from(["<x/>", "", "<fmiModelDescription/>"])))
                zf.writestr("resources/A.fmu", inner.getvalue())
            elif kind == "bomb":
                zf.writestr("resources/bomb.bin", b"\0" * (8 * 1024**2))
            elif kind == "escape":
                zf.writestr("../escaped.txt", "x")
            else:
                zf.writestr("resources/sub/", "")
    data = buf.getvalue()
    cut = draw(st.one_of(st.none(), st.none(), st.integers(0, len(data))))  # sometimes a cut archive
    return data if cut is None else data[:cut]


# -- run CSVs -------------------------------------------------------------------------------------
RUN_COLUMNS = ["t", "B1", "theta2", "B2", "theta3", "B3", "theta4", "theta2_d", "theta3_d", "theta4_d", "Fx",
               "Fy", "KE", "PE", "E", "closure_error", "tau_drive", "P_drive"]


@st.composite
def run_csv(draw) -> bytes:
    """A run CSV: well formed with finite values (half the time), or broken in one of many ways."""
    shape = draw(st.sampled_from(["good", "good", "broken", "bytes"]))
    if shape == "bytes":
        return draw(st.binary(max_size=200))
    cols = draw(st.lists(st.sampled_from(RUN_COLUMNS + ["mech.theta2", "x", "", "t"]), min_size=1, max_size=10))
    if shape == "good":
        if draw(st.integers(0, 3)):  # mostly with every coordinate of the four-bar, so it can be drawn
            cols = RUN_COLUMNS[:7] + cols
        cols = ["t"] + [c for c in dict.fromkeys(cols) if c and c != "t"]
        n = draw(st.integers(1, 6))
        steps = draw(st.lists(st.floats(1e-3, 1.0), min_size=n, max_size=n))
        t = [sum(steps[:k]) for k in range(n)]
        rows = [[repr(t[k])] + [repr(draw(st.floats(-1e3, 1e3))) for _ in cols[1:]] for k in range(n)]
    else:
        n = draw(st.integers(0, 5))
        cell = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.sampled_from(NASTY_TEXT))
        rows = [[draw(cell) for _ in range(draw(st.integers(0, len(cols) + 1)))] for _ in range(n)]
    text = "\n".join(",".join(r) for r in [cols] + rows) + "\n"
    return text.encode("utf-8", "surrogatepass")
