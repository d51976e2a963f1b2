"""Sweeps: local processes and a real Dask cluster give the same table; failures are
rows; an interrupted sweep resumes without redoing finished points."""

import csv
import functools

import numpy as np
import pytest

from grubler import GrublerError
from grubler.studies.sweep import grid, parse_axis, run_sweep, scene_point

import process_state

CALLS = []


def counted(x: float) -> dict:
    CALLS.append(x)
    return {"y": 2 * x}


def scene_points():
    return grid(**{"link2.a": [0.15, 0.2], "link3.m": [2.0, -1.0]})


def same_rows(a, b, skip=("seconds", "run_seconds")):
    assert len(a.rows) == len(b.rows)
    for ra, rb in zip(a.rows, b.rows):
        assert set(ra) == set(rb)
        for k in ra:
            if k not in skip:
                assert ra[k] == rb[k], k


def test_local_processes_and_a_dask_cluster_give_the_same_table(tmp_path):
    distributed = pytest.importorskip("distributed")
    func = functools.partial(scene_point, "thesis-fourbar", t_end=0.3)
    serial = run_sweep(func, scene_points(), workers=1, progress=False)
    local = run_sweep(func, scene_points(), out=tmp_path / "local.csv", workers=2, progress=False)
    # LocalCluster writes its workers' settings (OMP_NUM_THREADS=1, PYTHONHASHSEED, ...) into this process's
    # os.environ and leaves them there, for every child process of every later test to inherit
    with process_state.environ_kept(), distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                                                dashboard_address=None) as cluster:
        dask = run_sweep(func, scene_points(), out=tmp_path / "dask.csv", scheduler=cluster.scheduler_address,
                         progress=False)
    assert "2 workers" in dask.workers and local.workers == "2 processes"
    same_rows(serial, local)
    same_rows(serial, dask)
    # the mass -1 points failed with the model's own message, the others ran
    statuses = [r["status"] for r in serial.rows]
    assert statuses == ["ok", "failed", "ok", "failed"]
    assert serial.rows[1]["error"] == "SceneError: link3.m: mass must be positive, got -1.0"
    assert serial.rows[0]["max_closure_error"] < 1e-10
    # the written tables agree too
    a, b = (list(csv.DictReader(open(tmp_path / f))) for f in ("local.csv", "dask.csv"))
    for ra, rb in zip(a, b):
        for k in ("seconds [s]", "run_seconds"):  # wall times; the sweep's own in seconds, as its heading says
            ra.pop(k), rb.pop(k)
        assert ra == rb
    assert len(a) == 4


def test_an_interrupted_sweep_resumes_without_redoing_points(tmp_path):
    out = tmp_path / "s.csv"
    points = grid(x=[1.0, 2.0, 3.0, 4.0])
    CALLS.clear()
    run_sweep(counted, points, out=out, workers=1, progress=False)
    assert CALLS == [1.0, 2.0, 3.0, 4.0]
    # cut the journal as an interruption after two points would have left it
    journal = tmp_path / "s.csv.journal.jsonl"
    lines = journal.read_text().splitlines()
    journal.write_text("\n".join(lines[:3]) + "\n" + lines[3][:10])  # and a half-written line
    out.unlink()
    CALLS.clear()
    table = run_sweep(counted, points, out=out, workers=1, progress=False)
    assert CALLS == [3.0, 4.0]
    assert table.resumed == 2
    assert table.column("y") == [2.0, 4.0, 6.0, 8.0]
    assert out.read_text().splitlines()[0] == "x,y,status,error,seconds [s],key"  # the units a sweep knows
    # a different sweep refuses the journal instead of mixing results
    with pytest.raises(GrublerError, match="its journal is of another sweep"):
        run_sweep(functools.partial(scene_point, "thesis-fourbar"), grid(**{"link2.a": [0.2]}), out=out,
                  workers=1, progress=False)


def test_parquet_table(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")
    table = run_sweep(counted, grid(x=[1.0, 5.0]), out=tmp_path / "s.parquet", workers=1, progress=False)
    back = pq.read_table(tmp_path / "s.parquet").to_pydict()
    assert back["y"] == [2.0, 10.0] and back["status"] == ["ok", "ok"]
    assert table.columns == list(back)


def test_axes_and_points_are_checked():
    assert parse_axis("drive.torque=1:3:3") == ("drive.torque", [1.0, 2.0, 3.0])
    for bad in ("link2.a", "link2.a=", "x=1:2:zero"):
        with pytest.raises(GrublerError, match="--set"):
            parse_axis(bad)
    with pytest.raises(GrublerError, match="point 1 has keys"):
        run_sweep(counted, [{"x": 1.0}, {"y": 2.0}], workers=1, progress=False)
