"""liebridge.batch: one picklable call per log, the same numbers as ``liebridge traj``, any engine.

The rows of :func:`liebridge.batch.evaluate` are checked against the single-file command's JSON;
the engines against each other; failures, resumption and the command line's errors on their own.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import math
import pickle
import socket
import time
from pathlib import Path

import numpy as np
import pytest
from _batch_data import BROKEN, environment_job, make_fleet, make_pair, trajectory, write_manifest

import liebridge as lb
from liebridge import batch
from liebridge.cli import main
from liebridge.io import trajfile

RTOL = 1e-12  # same code path on the same machine; no bit-for-bit promise across BLAS builds


def _cli(args: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    return rc, out.getvalue(), err.getvalue()


def _close(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose(a, b, rel_tol=RTOL, abs_tol=1e-300) or (math.isnan(a) and math.isnan(b))
    return a == b


def _same_rows(A: list[dict], B: list[dict]) -> None:
    assert len(A) == len(B)
    for i, (a, b) in enumerate(zip(A, B, strict=True)):
        assert list(a) == list(b), i
        bad = {k: (a[k], b[k]) for k in a if not _close(a[k], b[k])}
        assert not bad, (i, bad)


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    d = tmp_path_factory.mktemp("fleet")
    rows = make_fleet(
        d, 10, 400, broken={1: "garbage", 2: "missing", 4: "nan", 5: "no_overlap"}, cov_every=3
    )
    write_manifest(d / "manifest.csv", rows)
    return d, rows


# --------------------------------------------------------------------------- one call per log


@pytest.mark.parametrize("align", ["none", "se3", "sim3"])
def test_evaluate_equals_the_single_file_command(fleet, align):
    _, rows = fleet
    r = rows[0]  # has covariances, in GTSAM's convention
    row = batch.evaluate(
        r["ref"], r["est"], align=align, est_cov=r["est_cov"], convention=r["convention"]
    )
    assert row["status"] == "ok", row["error"]
    json.dumps(row, allow_nan=False)  # flat and JSON-ready
    common = [r["ref"], r["est"], "--align", align, "--format", "json"]
    for metric, extra in (
        ("ape", []),
        ("rpe", []),
        ("nees", ["--cov", r["est_cov"], "--convention", r["convention"]]),
    ):
        rc, out, err = _cli(["traj", metric, *common, *extra])
        assert rc == 0, err
        ref = json.loads(out)
        for k in ("rmse", "mean", "median", "std", "min", "max"):
            assert _close(row[f"{metric}_{k}"], ref[k]), (metric, k, row[f"{metric}_{k}"], ref[k])
        assert row["n_associated"] == ref["n_associated"]
        assert _close(row["scale"], ref["scale"])
        if metric == "nees":
            for k in ("anees", "anees_lower", "anees_upper", "fraction_inside", "consistent"):
                assert _close(row[f"nees_{k}"], ref[k]), k


def test_evaluate_options_reach_the_metrics(fleet):
    _, rows = fleet
    r = rows[3]
    row = batch.evaluate(
        r["ref"], r["est"], metrics="rpe", pose_relation="angle_deg", delta=5.0, all_pairs=True
    )
    rc, out, err = _cli(
        [
            "traj",
            "rpe",
            r["ref"],
            r["est"],
            "-r",
            "angle_deg",
            "--delta",
            "5",
            "--all-pairs",
            "--format",
            "json",
        ]
    )
    assert rc == 0, err
    ref = json.loads(out)
    assert row["rpe_n"] == ref["n"] and _close(row["rpe_rmse"], ref["rmse"])
    assert "ape_rmse" not in row and "nees_anees" not in row  # only the metrics asked for


@pytest.mark.parametrize("kind", BROKEN)
def test_a_broken_log_is_an_error_row_naming_it(tmp_path, kind):
    r = make_pair(tmp_path, 7, 50, broken=kind)
    row = batch.evaluate(r["ref"], r["est"])
    ok = batch.evaluate(**make_pair(tmp_path, 8, 50))
    assert row["status"] == "error" and row["error"]
    assert list(row) == list(ok)  # the same columns, success or not
    assert row["ape_rmse"] is None
    if kind != "no_overlap":
        assert "run0007" in row["error"]
    json.dumps(row, allow_nan=False)


def test_nees_without_covariances_is_skipped_with_a_note(fleet):
    _, rows = fleet
    row = batch.evaluate(rows[3]["ref"], rows[3]["est"])
    assert row["status"] == "ok"
    assert "nees skipped" in row["note"] and row["nees_anees"] is None
    assert row["ape_rmse"] is not None


def test_the_callers_mistakes_raise(fleet):
    _, rows = fleet
    with pytest.raises(TypeError, match=r"unknown option.*algin"):
        batch.evaluate(rows[0]["ref"], rows[0]["est"], algin="se3")
    with pytest.raises(ValueError, match="metrics"):
        batch.evaluate(rows[0]["ref"], rows[0]["est"], metrics=("ape", "ate"))
    with pytest.raises(TypeError, match="unknown option"):
        batch.convert(rows[0]["est"], ".", fmt="tum")


def test_the_functions_pickle_by_reference():
    assert pickle.loads(pickle.dumps(batch.evaluate)) is batch.evaluate
    assert pickle.loads(pickle.dumps(batch.convert)) is batch.convert
    assert lb.batch is batch


def test_evaluate_reads_a_bag_topic_and_its_covariances(tmp_path):
    pytest.importorskip("rosbags")
    from liebridge import ros

    t, T = trajectory(200, 3)
    rng = np.random.default_rng(5)
    sigma = np.array([0.002, 0.002, 0.002, 0.02, 0.02, 0.02])  # GTSAM (ω, v)
    T_est = T @ lb.lie.se3.exp(rng.normal(size=(200, 6)) * sigma)
    C = np.tile(np.diag(sigma**2), (200, 1, 1))
    trajfile.write_trajectory(tmp_path / "ref.txt", t, T)
    trajfile.write_trajectory(tmp_path / "est.txt", t, T_est)
    np.save(tmp_path / "cov_gtsam.npy", C)
    msgs = ros.from_poses(T_est, C, convention="gtsam", stamps=t)
    bag = ros.write_messages(tmp_path / "est.bag", "/est/pose", msgs, storage="rosbag1")
    row = batch.evaluate(tmp_path / "ref.txt", f"{bag}:/est/pose")
    assert row["status"] == "ok", row["error"]
    assert row["convention"] == "ros"
    # the bag's covariances, as stored (ROS order), give the command's NEES with them ...
    np.save(tmp_path / "cov_ros.npy", ros.read_messages(bag, "/est/pose").cov)
    rc, out, err = _cli(
        [
            "traj",
            "nees",
            str(tmp_path / "ref.txt"),
            str(tmp_path / "est.txt"),
            "--cov",
            str(tmp_path / "cov_ros.npy"),
            "--convention",
            "ros",
            "--format",
            "json",
        ]
    )
    assert rc == 0, err
    assert math.isclose(row["nees_anees"], json.loads(out)["anees"], rel_tol=1e-9)
    # ... and agree to first order with the same covariances given in GTSAM's order; read in
    # the wrong order (rotation and translation variances swapped) they would be 100x off
    rc, out, _ = _cli(
        [
            "traj",
            "nees",
            str(tmp_path / "ref.txt"),
            str(tmp_path / "est.txt"),
            "--cov",
            str(tmp_path / "cov_gtsam.npy"),
            "--convention",
            "gtsam",
            "--format",
            "json",
        ]
    )
    assert math.isclose(row["nees_anees"], json.loads(out)["anees"], rel_tol=0.05)


# --------------------------------------------------------------------------- convert


@pytest.mark.parametrize("to", ["tum", "euroc", "kitti"])
def test_convert_writes_a_file_that_reads_back(fleet, tmp_path, to):
    _, rows = fleet
    row = batch.convert(rows[0]["est"], tmp_path, to=to, cov=rows[0]["est_cov"], convention="gtsam")
    assert row["status"] == "ok", row["error"]
    t0, T0 = trajfile.read_trajectory(rows[0]["est"])
    t1, T1 = trajfile.read_trajectory(row["dst"], to)
    assert row["n_poses"] == len(t0) == len(t1)
    np.testing.assert_allclose(T1, T0, atol=1e-12)
    if to != "kitti":
        np.testing.assert_allclose(t1, t0, atol=1e-6 if to == "euroc" else 0)
    np.testing.assert_array_equal(np.load(row["cov_file"]), np.load(rows[0]["est_cov"]))
    assert not list(tmp_path.glob(".*part*"))


def test_convert_failure_is_a_row(fleet, tmp_path):
    _, rows = fleet
    row = batch.convert(rows[1]["est"], tmp_path, to="tum")
    assert row["status"] == "error" and "run0001" in row["error"]
    assert batch.convert(rows[0]["est"], tmp_path, to="g2o")["status"] == "error"


# --------------------------------------------------------------------------- engines and tables


def _jobs(rows: list[dict]) -> list[dict]:
    return [dict(r) for r in rows]


def test_engines_give_identical_tables(fleet, tmp_path):
    distributed = pytest.importorskip("distributed")
    _, rows = fleet
    jobs = _jobs(rows)
    serial = batch.run(batch.evaluate, jobs, tmp_path / "serial.csv")
    procs = batch.run(batch.evaluate, jobs, tmp_path / "procs.csv", engine="processes", workers=2)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        dask = batch.run(
            batch.evaluate, jobs, tmp_path / "dask.csv", engine="dask", scheduler=client
        )
    _same_rows(serial.rows, procs.rows)
    _same_rows(serial.rows, dask.rows)
    assert [r["ref"] for r in serial.rows] == [j["ref"] for j in jobs]  # job order
    assert {r["est"].rsplit("/", 1)[1] for r in serial.failed} == {
        f"run000{k}_est.txt" for k in (1, 2, 4, 5)
    }
    csv_s = (tmp_path / "serial.csv").read_text().splitlines()
    csv_p = (tmp_path / "procs.csv").read_text().splitlines()
    assert csv_s[0] == csv_p[0] and len(csv_s) == len(jobs) + 1


def test_process_workers_get_one_blas_thread_and_the_callers_env_wins(monkeypatch):
    """Two workers with two BLAS threads each oversubscribe two cores: one each, as dask's."""
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    monkeypatch.setenv("OMP_NUM_THREADS", "3")  # the caller's own setting is kept
    names = "OPENBLAS_NUM_THREADS,OMP_NUM_THREADS"
    rows = [r for _, r in batch.map_jobs(environment_job, [{"names": names}] * 2,
                                         engine="processes", workers=2)]  # fmt: skip
    assert rows == [{"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "3"}] * 2
    assert "OPENBLAS_NUM_THREADS" not in __import__("os").environ  # the parent's is restored


def test_a_rerun_after_interruption_computes_only_what_is_missing(fleet, tmp_path):
    _, rows = fleet
    jobs = _jobs(rows)
    out = tmp_path / "t.csv"

    def stop_after_4(done, total, failed, rate, eta):
        if done == 4:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        batch.run(batch.evaluate, jobs, out, progress=stop_after_4)
    assert not out.exists()
    journal = out.with_suffix(".jsonl")
    assert len(journal.read_text().splitlines()) == 4
    with open(journal, "a") as fh:  # a line cut short by a kill
        fh.write('{"job": "abc", "ref": "x')
    seen = []
    res = batch.run(batch.evaluate, jobs, out, progress=lambda *a: seen.append(a))
    assert (res.reused, res.computed) == (4, len(jobs) - 4)
    assert seen[-1][:2] == (len(jobs) - 4, len(jobs) - 4)
    _same_rows(res.rows, batch.run(batch.evaluate, jobs).rows)
    again = batch.run(batch.evaluate, jobs, out)
    assert (again.reused, again.computed) == (len(jobs), 0)
    retry = batch.run(batch.evaluate, jobs, out, retry_errors=True)
    assert retry.computed == len(retry.failed) == 4


def test_table_files(fleet, tmp_path):
    _, rows = fleet
    res = batch.run(batch.evaluate, _jobs(rows), tmp_path / "t.csv")
    with open(tmp_path / "t.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == len(rows)
    for got, row in zip(table, res.rows, strict=True):
        if row["ape_rmse"] is not None:
            assert float(got["ape_rmse"]) == row["ape_rmse"]  # repr: reads back exactly
        assert got["status"] == row["status"]
    pq = pytest.importorskip("pyarrow.parquet")
    assert pq.read_table(tmp_path / "t.parquet").to_pylist() == [
        {k: r[k] for k in table[0]} for r in res.rows
    ]


def test_summary_lists_worst_runs_first_and_plots(fleet, tmp_path):
    pytest.importorskip("matplotlib")
    _, rows = fleet
    res = batch.run(batch.evaluate, _jobs(rows))
    lines = batch.summary_lines(res.rows)
    assert lines[0] == f"{len(rows)} logs: {len(rows) - 4} ok, 4 failed"
    i = lines.index(next(s for s in lines if s.startswith("ape_rmse")))
    worst = [float(s.split()[0]) for s in lines[i + 1 : i + 6]]
    assert worst == sorted(worst, reverse=True)
    best = max(r["ape_rmse"] for r in res.rows if r["ape_rmse"] is not None)
    assert math.isclose(worst[0], best, rel_tol=1e-3)  # printed with 4 digits
    assert sum(s.startswith("FAILED") for s in lines) == 4
    assert batch.plot_summary(res.rows, tmp_path / "s.png")
    assert (tmp_path / "s.png").stat().st_size > 10_000


def test_engine_arguments_are_checked():
    with pytest.raises(ValueError, match="engine"):
        list(batch.map_jobs(batch.evaluate, [], engine="ray"))
    with pytest.raises(ValueError, match="workers"):
        list(batch.map_jobs(batch.evaluate, [], engine="processes", workers=0))
    with pytest.raises(ValueError, match="scheduler"):
        list(batch.map_jobs(batch.evaluate, [], scheduler="tcp://x:1"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_a_scheduler_that_does_not_answer_fails_fast():
    pytest.importorskip("distributed")
    t0 = time.perf_counter()
    with pytest.raises(ConnectionError, match="no Dask scheduler answered"):
        list(
            batch.map_jobs(
                batch.evaluate,
                [{"ref": "a", "est": "b"}],
                engine="dask",
                scheduler=f"tcp://127.0.0.1:{_free_port()}",
                connect_timeout=2.0,
            )
        )
    assert time.perf_counter() - t0 < 20


# --------------------------------------------------------------------------- command line


def test_cli_manifest_with_missing_files_runs_the_rest(fleet, tmp_path):
    d, _ = fleet
    out = tmp_path / "r.csv"
    rc, stdout, err = _cli(["batch", "evaluate", str(d / "manifest.csv"), "--out", str(out)])
    assert rc == 1  # some logs failed
    assert "1 of 10 jobs name missing files" in err and "run0002_est.txt: no such file" in err
    assert "10/10 logs, 4 failed" in err and "logs/s" in err
    assert stdout.startswith("10 logs: 6 ok, 4 failed")
    assert out.is_file() and out.with_suffix(".png").is_file()
    rc, _, err = _cli(["batch", "evaluate", str(d / "manifest.csv"), "--out", str(out)])
    assert "10 of 10 logs already in" in err and "0 computed" in err


def test_cli_equals_the_api_with_per_row_options(fleet, tmp_path):
    _, rows = fleet
    m = tmp_path / "m.csv"
    m.write_text(
        "ref,est,align,delta,metrics\n"
        f"{rows[3]['ref']},{rows[3]['est']},se3,2,ape;rpe\n"
        f"{rows[6]['ref']},{rows[6]['est']},,,\n"
    )
    rc, _, err = _cli(
        [
            "batch",
            "evaluate",
            str(m),
            "--out",
            str(tmp_path / "r.csv"),
            "--align",
            "sim3",
            "--no-summary",
            "--quiet",
        ]
    )
    assert rc == 0, err
    table = list(csv.DictReader(open(tmp_path / "r.csv", newline="")))
    a = batch.evaluate(rows[3]["ref"], rows[3]["est"], metrics="ape,rpe", align="se3", delta=2.0)
    b = batch.evaluate(rows[6]["ref"], rows[6]["est"], align="sim3")
    assert float(table[0]["rpe_rmse"]) == a["rpe_rmse"] and table[0]["align"] == "se3"
    assert float(table[1]["ape_rmse"]) == b["ape_rmse"] and table[1]["align"] == "sim3"


def test_cli_directory_pairing_and_convert(fleet, tmp_path):
    d, _ = fleet
    rc, out, err = _cli(
        [
            "batch",
            "evaluate",
            str(d),
            "--out",
            str(tmp_path / "r.csv"),
            "--cov-glob",
            "*_est.cov.npy",
            "--convention",
            "gtsam",
            "--engine",
            "processes",
            "--jobs",
            "2",
            "--no-summary",
        ]
    )
    assert rc == 1
    assert "left out" in err  # run0002 has no EST
    assert out.startswith("9 logs: 6 ok, 3 failed")
    assert "nees_anees" in out
    dst = tmp_path / "kitti"
    dst.mkdir()
    rc, out, err = _cli(
        [
            "batch",
            "convert",
            str(d),
            "--glob",
            "*_ref.txt",
            "--dst-dir",
            str(dst),
            "--to",
            "kitti",
            "--out",
            str(tmp_path / "c.csv"),
        ]
    )
    assert rc == 1 and out.startswith("10 logs: 9 ok, 1 failed")  # the NaN reference
    assert len(list(dst.glob("*_ref.txt"))) == 9


@pytest.mark.parametrize(
    "args, message",
    [
        (["evaluate", "{d}/nothing.csv"], "SOURCE: no such file or directory"),
        (["evaluate", "{d}", "--ref-glob", "*.gt"], "no pairs: 0 files match --ref-glob"),
        (["evaluate", "{d}", "--ref-glob", "a*b*"], "exactly one '*'"),
        (["evaluate", "{d}/manifest.csv", "--metrics", "ape,ate"], "--metrics"),
        (["evaluate", "{d}/manifest.csv", "--scheduler", "tcp://x:1"], "only the dask engine"),
        (["evaluate", "{d}/bad_header.csv"], "unknown column(s) algin"),
        (["evaluate", "{d}/bad_cell.csv"], "data line 2: max_diff: not a number: 'soon'"),
        (["convert", "{d}", "--dst-dir", "{d}/nowhere"], "--dst-dir"),
    ],
)
def test_cli_usage_errors_are_one_line(fleet, tmp_path, args, message):
    d, rows = fleet
    (d / "bad_header.csv").write_text(f"ref,est,algin\n{rows[0]['ref']},{rows[0]['est']},se3\n")
    (d / "bad_cell.csv").write_text(f"ref,est,max_diff\n{rows[0]['ref']},{rows[0]['est']},soon\n")
    argv = ["batch", *[a.format(d=d) for a in args], "--out", str(tmp_path / "r.csv")]
    rc, _, err = _cli(argv)
    assert rc == 2
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err


def test_cli_scheduler_that_does_not_answer(fleet, tmp_path):
    pytest.importorskip("distributed")
    d, _ = fleet
    t0 = time.perf_counter()
    rc, _, err = _cli(
        [
            "batch",
            "evaluate",
            str(d / "manifest.csv"),
            "--out",
            str(tmp_path / "r.csv"),
            "--engine",
            "dask",
            "--scheduler",
            f"tcp://127.0.0.1:{_free_port()}",
        ]
    )
    assert rc == 2 and "no Dask scheduler answered" in err.splitlines()[-1]
    assert time.perf_counter() - t0 < 30


# --------------------------------------------------------------------------- docs, benchmark


def test_the_fleet_page_runs(tmp_path, monkeypatch):
    import re

    page = Path(__file__).resolve().parents[1] / "docs" / "fleet.md"
    blocks = re.findall(r"^```python\n(.*?)^```", page.read_text(encoding="utf-8"), re.M | re.S)
    assert blocks
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "fleet_page"}
    for k, code in enumerate(blocks):
        with contextlib.redirect_stdout(io.StringIO()):
            exec(compile(code, f"fleet.md[block {k}]", "exec"), namespace)
    rc, out, err = _cli(["batch", "evaluate", "fleet/manifest.csv", "--out", "cli.csv",
                         "--align", "se3", "--engine", "processes", "--jobs", "2"])  # fmt: skip
    assert rc == 1 and out.startswith("6 logs: 5 ok, 1 failed"), err


def test_bench_batch_quick(tmp_path):
    import os
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    out = tmp_path / "batch.json"
    proc = subprocess.run(
        [sys.executable, str(root / "benchmarks" / "bench_batch.py"), str(out), "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=root,
        env={
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")]),
        },
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(out.read_text())
    engines = [r["engine"] for r in res["rows"]]
    assert engines[:3] == ["hand loop", "serial", "processes"]
    assert all(r["logs_per_s"] > 0 for r in res["rows"])


# --------------------------------------------------------------------------- acceptance (slow)


@pytest.mark.slow
def test_acceptance_500_pairs_every_engine(tmp_path):
    """500 pairs of 10⁴ poses, a few broken: serial, processes and a 2-worker LocalCluster give
    identical tables; broken files are error rows; a rerun after interruption computes only
    what is missing."""
    pytest.importorskip("distributed")
    broken = {k: BROKEN[i % len(BROKEN)] for i, k in enumerate((7, 111, 222, 333, 444, 499))}
    rows = make_fleet(tmp_path, 500, 10_000, broken=broken, cov_every=5)
    jobs = _jobs(rows)
    serial = batch.run(batch.evaluate, jobs, tmp_path / "serial.csv")
    assert sorted(int(Path(r["est"]).name[3:7]) for r in serial.failed) == sorted(broken)
    procs = batch.run(batch.evaluate, jobs, tmp_path / "procs.csv", engine="processes", workers=2)
    _same_rows(serial.rows, procs.rows)

    def stop_after(n):
        def progress(done, *_):
            if done == n:
                raise KeyboardInterrupt

        return progress

    with pytest.raises(KeyboardInterrupt):  # a dask run interrupted after 200 logs ...
        batch.run(batch.evaluate, jobs, tmp_path / "dask.csv", engine="dask", workers=2,
                  progress=stop_after(200))  # fmt: skip
    dask = batch.run(batch.evaluate, jobs, tmp_path / "dask.csv", engine="dask", workers=2)
    assert (dask.reused, dask.computed) == (200, 300)  # ... computes only the other 300
    _same_rows(serial.rows, dask.rows)


def test_convert_a_bag_topic_with_its_covariances(tmp_path):
    pytest.importorskip("rosbags")
    from liebridge import ros

    t, T = trajectory(50, 4)
    rng = np.random.default_rng(9)
    A = rng.normal(size=(50, 6, 6)) * 0.01
    C = A @ A.transpose(0, 2, 1) + 1e-4 * np.eye(6)  # full covariances in GTSAM's (ω, v)
    ros.write_messages(
        tmp_path / "run.bag",
        "/odom",
        ros.from_poses(T, C, convention="gtsam", stamps=t),
        storage="rosbag1",
    )
    dst = tmp_path / "out"
    dst.mkdir()
    rc, _, err = _cli(["batch", "convert", str(tmp_path), "--glob", "*.bag", "--src-topic",
                       "/odom", "--dst-dir", str(dst), "--convention", "gtsam", "--out",
                       str(tmp_path / "c.csv")])  # fmt: skip
    assert rc == 0, err
    t1, T1 = trajfile.read_trajectory(dst / "run_odom.txt")
    np.testing.assert_allclose(T1, T, atol=1e-12)
    np.testing.assert_allclose(t1, t, atol=1e-9)  # nanosecond stamps
    np.testing.assert_allclose(np.load(dst / "run_odom.cov.npy"), C, rtol=1e-9, atol=1e-15)
