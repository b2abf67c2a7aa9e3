import argparse
import csv
import json
import logging
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest
from cardan_forces.experiments import sweep

from cardan_forces.cli import main

ARGS = ["sweep", "--angle", "0", "--angle", "30", "--amplitude", "-5", "--formulation",
        "min_norm", "--formulation", "positive", "--quick"]
TIMES = ("simulate_s", "solve_s", "total_s")


def rows(folder):
    with open(folder / "sweep.csv", newline="") as f:
        return list(csv.DictReader(f))


def by_key(table):
    return {tuple(r[k] for k in sweep.KEY): r for r in table}


def same_results(a, b):
    """Equal rows up to timing and round-off (forces to 1e-6 relative)."""
    assert a.keys() == b.keys()
    for key in a:
        for column in sweep.COLUMNS:
            x, y = a[key][column], b[key][column]
            if column in TIMES or column == "max_equilibrium":
                continue
            if column in sweep.PEAKS or column.startswith("speed_ratio"):
                assert float(x) == pytest.approx(float(y), rel=1e-6, abs=1e-9), (key, column)
            else:
                assert x == y, (key, column)


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """The tiny sweep on the process pool: 2 angles x 1 amplitude x 2 formulations."""
    out = tmp_path_factory.mktemp("sweep")
    assert main([*ARGS, "--workers", "2", "--out", str(out)]) == 0
    return out


def test_pool_rows_and_physics(base):
    table = rows(base)
    # rows are appended as points finish, in any order
    assert sorted((r["angle_deg"], r["formulation"]) for r in table) == [
        ("0", "min_norm"), ("0", "positive"), ("30", "min_norm"), ("30", "positive")]
    assert {r["solver"] for r in table} == {"numpy-kkt", "qpsolvers-daqp"}
    for r in table:
        assert r["status"] == "solved" and r["n_solved"] == "6"
        assert float(r["max_equilibrium"]) <= 1e-8
        assert r["amplitude_N_m"] == "-5" and r["instants"] == "6" and r["stop_s"] == "0.5"
        # Z arrangement, equal angles: the output turns with the input at any angle
        assert float(r["speed_ratio_output_max"]) == pytest.approx(1.0, abs=1e-12)
    at = {(r["angle_deg"], r["formulation"]): r for r in table}
    # behind one joint at gamma the second shaft peaks at 1/cos(gamma); straight: 1
    assert float(at["0", "min_norm"]["speed_ratio_shaft2_max"]) == pytest.approx(1.0, abs=1e-12)
    assert float(at["30", "min_norm"]["speed_ratio_shaft2_max"]) == pytest.approx(
        1 / math.cos(math.radians(30)), rel=1e-9)
    # a straight drive line loads its bearings only in the vertical (gravity) plane; at 30
    # deg the joints' secondary couples load them out of plane, and that load is
    # determinate, so every formulation gives the same
    for f in ("min_norm", "positive"):
        assert float(at["0", f]["peak_input_out_of_plane_N"]) < 1e-9
        assert float(at["0", f]["peak_input_radial_N"]) > 100.0
    bent = [float(at["30", f]["peak_input_out_of_plane_N"]) for f in ("min_norm", "positive")]
    assert bent[0] > 0.1 and bent[1] == pytest.approx(bent[0], rel=1e-6)
    report = (base / "sweep.md").read_text()
    assert "Cost per point" in report and "processes (2 workers)" in report
    assert "min_norm (numpy-kkt), positive (qpsolvers-daqp)" in report


def test_rerun_computes_nothing_and_prints_json(base, tmp_path, capsys):
    out = tmp_path / "again"
    shutil.copytree(base, out)
    before = (out / "sweep.csv").read_bytes()
    assert main([*ARGS, "--out", str(out), "--json"]) == 0
    captured = capsys.readouterr()
    assert "2 resumed" in captured.err and "0 to run" in captured.err
    assert (out / "sweep.csv").read_bytes() == before
    report = json.loads(captured.out)
    assert [r["formulation"] for r in report["rows"]] == [r["formulation"] for r in rows(out)]
    first = report["rows"][0]
    assert first["n_solved"] == 6 and isinstance(first["peak_joint1_N"], float)
    assert report["cost"]["points"] == 2 and report["cost"]["mean_s"] > 0


def test_deleted_row_and_cut_line_only_that_row_is_recomputed(base, tmp_path, capsys):
    out = tmp_path / "again"
    shutil.copytree(base, out)
    lines = (out / "sweep.csv").read_text().splitlines(keepends=True)
    gone = next(line for line in lines if line.startswith("paper,0.5,6,30,-5,positive,"))
    # the row deleted, and a killed sweep's half-written line at the end
    kept = [line for line in lines if line is not gone]
    (out / "sweep.csv").write_text("".join(kept) + gone[:40])
    assert main([*ARGS, "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "1 resumed" in err and "1 to run" in err
    old, new = by_key(rows(base)), by_key(rows(out))
    assert len(rows(out)) == 4
    same_results(old, new)
    for key, row in old.items():  # the untouched rows keep their timings: not recomputed
        if key[5] != "positive" or key[3] != "30":
            assert new[key] == row


def test_dask_gives_the_pool_rows(base, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, processes=False, threads_per_worker=1,
                                  dashboard_address=None) as cluster:
        assert main([*ARGS, "--out", str(tmp_path), "--scheduler",
                     cluster.scheduler_address]) == 0
    same_results(by_key(rows(base)), by_key(rows(tmp_path)))
    assert "Backend: dask at" in (tmp_path / "sweep.md").read_text()


def test_missing_dask_names_the_extra(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    assert main([*ARGS, "--out", str(tmp_path), "--scheduler", "tcp://127.0.0.1:8786"]) == 2
    assert 'pip install -e ".[dask]"' in capsys.readouterr().err
    assert not (tmp_path / "sweep.csv").exists()


def test_unreachable_scheduler_is_one_message(tmp_path, capsys):
    pytest.importorskip("distributed")
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    assert main([*ARGS, "--out", str(tmp_path), "--scheduler", f"tcp://127.0.0.1:{port}",
                 "--timeout", "0.5"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cardan: error: cannot reach the Dask scheduler") and "Traceback" \
        not in err


def test_bad_requests_exit_2(tmp_path, capsys):
    assert main(["sweep", "--formulation", "nonsense", "--out", str(tmp_path)]) == 2
    assert "argument --formulation: unknown formulation 'nonsense'" in capsys.readouterr().err
    constant = tmp_path / "constant.toml"
    constant.write_text('extends = "paper"\n[torque]\ninput = 10.0\n')
    for extra, message in (
        (["--formulation", "friction"], "needs a scene whose effects include 'friction'"),
        (["--formulation", "lcp", "--solver", "numpy-kkt"], "backends that do: lcp-lemke"),
        (["--solver", "no-such-backend"], "unknown backend"),
        (["--angles", "0:30"], "expected a number or a:b:n"),
        ([str(constant), "--amplitude", "5"], "input torque is constant"),
        (["--instants", "0"], "--instants 0: must be at least 1"),
    ):
        assert main(["sweep", "--quick", "--out", str(tmp_path), *extra]) == 2, extra
        assert message in capsys.readouterr().err
    assert not (tmp_path / "sweep.csv").exists()


def test_unphysical_angle_is_refused_and_a_failed_row(tmp_path, capsys):
    """The command line refuses it before any work; a point that still meets it (a
    worker's scene) ends as a failed row, not a crash."""
    assert main(["sweep", "--angles", "90:95:2", "--formulation", "min_norm", "--quick",
                 "--workers", "1", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err == ("cardan: error: --angle 90: |articulation| must be at "
                                       "most 89 deg\n")
    parser = argparse.ArgumentParser()
    sweep.add_parser(parser.add_subparsers())
    study = sweep.plan(parser.parse_args(["sweep", "--angle", "10", "--formulation",
                                          "min_norm", "--quick"]))
    (row,) = sweep.run_point(study.point(95.0, 0.0))
    assert row.status == "failed" and row.max_equilibrium == math.inf
    assert "95 deg is outside -89 to 89 deg" in row.message


def test_point_scene_sets_every_joint_and_the_amplitude():
    parser = argparse.ArgumentParser()
    sweep.add_parser(parser.add_subparsers())
    study = sweep.plan(parser.parse_args(["sweep", "--angle", "12", "--amplitude", "7",
                                          "--formulation", "min_norm"]))
    scene = sweep.point_scene(study.point(12.0, 7.0))
    assert [j.articulation_deg for j in scene.joints] == [12.0, 12.0]
    torque = scene.input_torque
    assert (torque.mean_N_m, torque.amplitude_N_m, torque.frequency_hz) == (10.0, 7.0, 1.0)
    assert study.methods == (("min_norm", "numpy-kkt"),)


@pytest.mark.slow
def test_ctrl_c_stops_the_workers_at_once_and_keeps_the_csv_whole(tmp_path):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) once the first
    point's row is in the CSV: the queued points are dropped and the point in flight is
    not finished (each takes seconds here), one line on stderr, exit 130, and the CSV
    holds whole rows only, which a rerun resumes. 1000 instants: a point takes several
    times the stop's latency, and the test waits for one point only."""
    args = ["sweep", "--angle", "5:20:4", "--instants", "1000", "--formulation", "min_max",
            "--workers", "2", "--out", str(tmp_path)]
    proc = subprocess.Popen([sys.executable, "-m", "cardan_forces.cli", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    path = tmp_path / "sweep.csv"
    deadline = time.monotonic() + 240
    while (not path.exists() or path.read_text().count("\n") < 2) and proc.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.05)
    first_point = time.monotonic()
    os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    stopped_after = time.monotonic() - first_point
    assert proc.returncode == 130 and err.splitlines()[-1] == "cardan: interrupted"
    assert "Traceback" not in err
    # the other worker's point had as long to run as the first: finishing it (or the
    # queued ones) would take seconds more
    assert stopped_after < 0.5 * float(err.split(" s/point")[0].split()[-1]), err
    text = path.read_text()
    assert text.endswith("\n")
    table = rows(tmp_path)
    assert 1 <= len(table) < 4 and all(None not in r.values() for r in table)
    assert {r["status"] for r in table} <= {"solved", "inaccurate"}


@pytest.mark.parametrize("extra,message", [
    (["--angles", "0:45:30000"], "30000 values; at most 1000"),
    (["--stop", "100000"], "periods; at most"),
    (["--angle", "10", "--amplitude", "0:1:900", "--instants", "300"], "solves: at most"),
    (["--amplitude", "2e9"], "must be at most 1e+09 N m"),
])
def test_requests_beyond_the_scene_limits_are_one_line_before_any_work(extra, message,
                                                                        tmp_path, capsys):
    assert main(["sweep", "--out", str(tmp_path), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cardan: error: ") and err.count("\n") == 1 and message in err
    assert not (tmp_path / "sweep.csv").exists()


@pytest.mark.parametrize("content", [b"\xff\xfe\x00 not text", b"a,b\n1,2\n",
                                     None])
def test_a_stored_file_that_is_no_sweep_csv_is_one_line(content, base, tmp_path, capsys):
    """Not UTF-8, other columns, a cell that does not read as its field's type: exit 2
    with the file named, and the file left as it was."""
    path = tmp_path / "sweep.csv"
    if content is None:  # a whole sweep CSV with one number cell spoiled
        text = (base / "sweep.csv").read_text()
        header, first, *rest = text.splitlines(keepends=True)
        cells = first.split(",")
        cells[2] = "six"  # instants
        content = (header + ",".join(cells) + "".join(rest)).encode()
    path.write_bytes(content)
    assert main([*ARGS, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cardan: error: ") and str(path) in err and err.count("\n") == 1
    assert path.read_bytes() == content


def test_rows_read_back_with_their_fields_types(base):
    from cardan_forces.experiments import sweep_store

    table = sweep_store.read_rows(base / "sweep.csv")
    assert len(table) == 4
    for row in table:
        assert isinstance(row.instants, int) and isinstance(row.angle_deg, float)
        assert row.status == "solved" and row.n_solved == 6
        assert sweep_store.parse(sweep_store.cells(row)) == row


@pytest.mark.parametrize("extra", [["--angle", "95"], ["--amplitude=-2e9"],
                                   ["--instants", "30000"], ["--stop", "100000"],
                                   ["--stop", "nan"], ["--workers", "0"],
                                   ["--timeout", "inf"]])
def test_the_plan_itself_holds_the_scene_limits(extra):
    """The sweep's own checks, without the command line's (a caller of ``plan``)."""
    parser = argparse.ArgumentParser()
    sweep.add_parser(parser.add_subparsers())
    with pytest.raises(sweep.SweepError):
        sweep.plan(parser.parse_args(["sweep", "--formulation", "min_norm", *extra]))


def test_duplicated_rows_are_stored_and_printed_once(base, tmp_path, capsys):
    """A CSV holding every row twice (as two writers would leave it): the rerun computes
    nothing, keeps one row per key in the file and in its answer, and says it resumed."""
    out = tmp_path / "twice"
    shutil.copytree(base, out)
    lines = (out / "sweep.csv").read_text().splitlines(keepends=True)
    (out / "sweep.csv").write_text(lines[0] + "".join(lines[1:] * 2))
    assert main([*ARGS, "--out", str(out), "--json"]) == 0
    captured = capsys.readouterr()
    assert "2 resumed" in captured.err and "0 to run" in captured.err
    assert "resumed: 2 point(s) were there, 0 computed now" in captured.err
    assert len(json.loads(captured.out)["rows"]) == 4
    assert (out / "sweep.csv").read_text() == "".join(lines)


def test_a_sweep_into_a_folder_another_sweep_writes_is_refused(base, tmp_path, capsys):
    """While one sweep holds a folder, a second into it is one line and exit 2, and the
    stored rows are untouched."""
    from cardan_forces.experiments.sweep_store import locked

    out = tmp_path / "busy"
    shutil.copytree(base, out)
    before = (out / "sweep.csv").read_bytes()
    with locked(out):
        assert main([*ARGS, "--angle", "10", "--out", str(out)]) == 2
    assert "another cardan sweep is writing into" in capsys.readouterr().err
    assert (out / "sweep.csv").read_bytes() == before


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (Linux /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] != "Z":
                found.append(int(entry))
    return found


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_killed_sweep_leaves_no_worker_running(tmp_path):
    """SIGKILL to the sweep (no cleanup runs) while its two workers compute: the
    workers end too, instead of computing points nobody will store."""
    args = ["sweep", "--angle", "5:20:4", "--instants", "6000", "--formulation", "min_max",
            "--workers", "2", "--out", str(tmp_path), "--quiet"]
    proc = subprocess.Popen([sys.executable, "-m", "cardan_forces.cli", *args],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        deadline = time.monotonic() + 240
        workers = []
        while len(workers) < 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
            workers = _children(proc.pid)
        assert len(workers) >= 2, "the sweep started no workers"
        time.sleep(1.0)  # the workers have started their points
        proc.kill()
        proc.wait(timeout=30)
        deadline = time.monotonic() + 10
        while any(map(_alive, workers)) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(map(_alive, workers))
    finally:
        proc.kill()
        for pid in workers if "workers" in locals() else ():
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_a_dask_run_without_workers_ends_after_the_timeout_keeping_its_rows(base, tmp_path,
                                                                           capsys):
    """A scheduler with no worker (all gone): the run ends after --timeout with one line
    per reason, exit 1, and the rows stored before are kept for a rerun."""
    distributed = pytest.importorskip("distributed")
    out = tmp_path / "gone"
    shutil.copytree(base, out)
    before = rows(out)
    with distributed.LocalCluster(n_workers=0, processes=False,
                                  dashboard_address=None) as cluster:
        started = time.monotonic()
        code = main([*ARGS, "--angle", "10", "--angle", "20", "--out", str(out),
                     "--scheduler", cluster.scheduler_address, "--timeout", "1"])
        took = time.monotonic() - started
    # distributed's own log handler may hold a stream an earlier test's capture closed:
    # its "Logging error" reports are the test run's, not the command's
    err = re.sub(r"--- Logging error ---.*?Arguments: .*?\n", "", capsys.readouterr().err,
                 flags=re.S)
    assert code == 1 and "Traceback" not in err
    assert "has had no worker for 1 s" in err
    assert took < 60
    assert rows(out) == before  # nothing lost, nothing added


@pytest.mark.parametrize("address", ["", "   "])
def test_an_empty_scheduler_address_is_refused(address, tmp_path, capsys):
    """An empty --scheduler is not a request to run here: one line, exit 2, no CSV."""
    assert main([*ARGS, "--out", str(tmp_path), "--scheduler", address]) == 2
    assert capsys.readouterr().err == (
        "cardan: error: --scheduler: the address is empty; give the scheduler's (as "
        "tcp://HOST:PORT), or leave --scheduler out to run here\n")
    assert not (tmp_path / "sweep.csv").exists()


def _close_workers(cluster) -> None:
    """Close every worker of an in-process LocalCluster at once, its tasks unfinished."""
    for worker in list(cluster.workers.values()):
        cluster.sync(worker.close, executor_wait=False)


def _echo(task):
    return [task]


def test_results_lost_with_their_workers_are_not_waited_for_past_the_timeout(monkeypatch):
    """Every worker closed after its tasks finished but before their results were
    gathered (Dask's client then reschedules them, for no worker): the run yields what
    it gathered and, by the deadline, one NoWorkers error for each other task, instead
    of waiting on a result for ever."""
    distributed = pytest.importorskip("distributed")
    import dask.distributed
    from cardan_forces.experiments import sweep_exec

    wait, looks = dask.distributed.wait, []

    def late_wait(*args, **kwargs):  # the first look comes once every task has finished
        if not looks:
            time.sleep(0.3)
        looks.append(1)
        return wait(*args, **kwargs)

    monkeypatch.setattr(dask.distributed, "wait", late_wait)
    with distributed.LocalCluster(n_workers=2, processes=False, threads_per_worker=1,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster.scheduler_address) as client:
        results = sweep_exec.dask(client, list(range(20)), 1.0, _echo, "task")
        first = [next(results)]
        _close_workers(cluster)
        rest, started = [], time.monotonic()
        reader = threading.Thread(target=lambda: rest.extend(results), daemon=True)
        reader.start()
        reader.join(timeout=15)
        took = time.monotonic() - started
    assert not reader.is_alive() and took < 5
    assert first[0][1] == [first[0][0]]
    assert sorted(task for task, _ in first + rest) == list(range(20))
    assert all(isinstance(r, sweep_exec.NoWorkers) for _, r in rest)
    assert "has had no worker for 1 s (--timeout); 19 task(s) not computed" in str(rest[0][1])


def test_a_dask_sweep_whose_workers_all_die_ends_at_the_timeout_keeping_its_rows(
        tmp_path, monkeypatch, capsys):
    """Every worker closed once the first point's rows are stored: the sweep ends about
    --timeout s later, exit 1, the timeout named, the stored rows kept."""
    distributed = pytest.importorskip("distributed")
    # Dask's log handlers keep the stderr of the test that first imported it, which
    # pytest has closed since: their failed writes are the test run's, not the sweep's.
    monkeypatch.setattr(logging, "raiseExceptions", False)
    append = sweep.append
    with distributed.LocalCluster(n_workers=1, processes=False, threads_per_worker=1,
                                  dashboard_address=None) as cluster:
        def append_then_close_workers(f, rows, header=False):
            append(f, rows, header)
            if rows:
                _close_workers(cluster)

        monkeypatch.setattr(sweep, "append", append_then_close_workers)
        started = time.monotonic()
        code = main(["sweep", "--angles", "0:30:6", "--formulation", "min_norm", "--quick",
                     "--out", str(tmp_path), "--scheduler", cluster.scheduler_address,
                     "--timeout", "1"])
        took = time.monotonic() - started
    err = capsys.readouterr().err
    assert code == 1 and took < 20 and "Traceback" not in err
    assert "has had no worker for 1 s (--timeout)" in err
    stored = rows(tmp_path)
    assert 1 <= len(stored) < 6 and all(r["status"] == "solved" for r in stored)


def test_an_edited_scene_is_computed_apart_from_its_old_rows(tmp_path, capsys):
    """A row's key holds the scene's content: the unchanged scene resumes, an edited one
    is computed anew (its old rows kept apart in the CSV, not reported as its own), and
    a point planned for the old content fails instead of solving the new."""
    scene, out = tmp_path / "line.toml", tmp_path / "out"
    scene.write_text('extends = "paper"\n')
    args = ["sweep", str(scene), "--angle", "10", "--formulation", "min_norm", "--quick",
            "--workers", "1", "--out", str(out), "--json"]
    assert main(args) == 0
    (first,) = json.loads(capsys.readouterr().out)["rows"]
    assert main(args) == 0
    assert "1 resumed" in capsys.readouterr().err
    scene.write_text('extends = "paper"\ngravity_m_s2 = [0.0, 0.0, -5.0]\n')
    assert main(args) == 0
    captured = capsys.readouterr()
    assert "0 resumed" in captured.err and "1 to run" in captured.err
    (after,) = json.loads(captured.out)["rows"]
    assert after["scene_sha256"] != first["scene_sha256"] and after["scene"] == first["scene"]
    assert after["peak_input_radial_N"] != pytest.approx(first["peak_input_radial_N"])
    assert {r["scene_sha256"] for r in rows(out)} == {first["scene_sha256"],
                                                      after["scene_sha256"]}
    stale = sweep.Point(str(scene), 0.5, 6, 10.0, 0.0, True, False,
                        (("min_norm", "numpy-kkt"),), first["scene_sha256"])
    (row,) = sweep.run_point(stale)
    assert row.status == "failed" and "its content changed" in row.message


def test_a_given_up_gather_leaves_no_traceback_on_stderr():
    """A gather given up at the deadline leaves Dask's inner task behind, which ends in
    Dask's own AllExit; asyncio's report of it (a traceback) is dropped once a Dask run
    has started, any other asyncio error still reported."""
    distributed = pytest.importorskip("distributed")
    from cardan_forces.experiments import sweep_exec

    sweep_exec._quiet_given_up_gathers()
    sweep_exec._quiet_given_up_gathers()  # once, however many runs
    log = logging.getLogger("asyncio")
    assert sum(isinstance(f, sweep_exec._GivenUpGathers) for f in log.filters) == 1

    def record(error):
        return log.makeRecord("asyncio", logging.ERROR, __file__, 0,
                              "Task exception was never retrieved", (),
                              (type(error), error, None))

    assert not log.filter(record(distributed.client.AllExit()))
    assert log.filter(record(ValueError("a real error")))
