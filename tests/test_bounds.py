"""The rest of the bad-input round: runs that cannot finish, archives that reach outside
themselves, broken FMUs, output options checked late, contradictory answers, interrupts.

Each test fails without the change it holds.
"""

import json
from pathlib import Path

import pytest

from grubler.cli import run
from grubler.sweep import _square, grid, run_sweep

ROOT = Path(__file__).parent.parent


def test_a_journal_torn_mid_line_is_resumed_on_a_fresh_line(tmp_path):
    out = tmp_path / "s.csv"
    points = grid(x=[1.0, 2.0, 3.0, 4.0])
    run_sweep(_square, points, out=out, workers=1, progress=False)
    journal = tmp_path / "s.csv.journal.jsonl"
    lines = journal.read_text().splitlines()
    # killed while writing the third row: the header, two rows and half a line
    journal.write_text("\n".join(lines[:3]) + "\n" + lines[3][: len(lines[3]) // 2])
    table = run_sweep(_square, points, out=out, workers=1, progress=False)
    assert table.resumed == 2 and table.column("y") == [1.0, 4.0, 9.0, 16.0]
    text = journal.read_text()
    assert text.endswith("\n")
    rows = [json.loads(line) for line in text.splitlines()[1:]]  # every line whole
    assert sorted(r["x"] for r in rows) == [1.0, 2.0, 3.0, 4.0]
    # a third run finds every point in the journal
    assert run_sweep(_square, points, out=out, workers=1, progress=False).resumed == 4


@pytest.mark.parametrize("argv, option", [
    (["linearize", "thesis-fourbar", "--json"], "--json"),
    (["linearize", "thesis-fourbar", "--bode"], "--bode"),
    (["export", "thesis-fourbar", "--out"], "--out"),
])
def test_every_output_option_is_checked_before_the_work_and_named(argv, option, tmp_path, capsys, monkeypatch):
    import importlib

    def no_work(*args, **kwargs):
        raise AssertionError("the work ran before its output path was checked")

    # (the package exports a function of the module's name: reach the modules themselves)
    monkeypatch.setattr(importlib.import_module("grubler.linearize"), "linearize", no_work)
    monkeypatch.setattr(importlib.import_module("grubler.fmi.build"), "export", no_work)
    assert run(argv + [str(tmp_path / "missing" / "x.png")]) == 2
    err = capsys.readouterr().err
    assert option in err and "does not exist" in err and len(err.splitlines()) == 1
