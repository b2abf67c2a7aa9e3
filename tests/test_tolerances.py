"""The tolerance study (``cardan tolerances``): zero tolerances give the compliance
answer, a seat misfit moves only the indeterminate loads and equals an independent
solve of the same energy, sampled loads stay in the rigid set, the store resumes
without losing or repeating a sample, the JSON is strict."""

import json
import re
import time

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.loading import load_scene
from cardan_forces.experiments import images
from cardan_forces.experiments import tolerance_store as store
from cardan_forces.experiments import tolerances as tol
from cardan_forces.experiments.environment import json_safe
from cardan_forces.experiments.study import solve_over_time
from cardan_forces.experiments.sweep_point import scene_digest
from cardan_forces.formulations.convex import contact_laws

from cardan_forces.cli import main

INSTANTS = 3


def _scene(tmp_path, extends: str, name: str, seat=0.0, angle=0.0, clearance=0.0,
           effects=None) -> str:
    path = tmp_path / f"{name}.toml"
    lines = [f'extends = "{extends}"', f'name = "{name}"']
    if effects:
        lines.append(f"effects = {json.dumps(effects)}")
    lines += ["[tolerances]", f"bearing_seat_m = {seat!r}", f"articulation_deg = {angle!r}",
              f"bearing_clearance_m = {clearance!r}"]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def _digest(spec: str) -> str:
    return scene_digest(load_scene(spec))


def _nominal(spec: str):
    return tol.nominal(spec, _digest(spec), INSTANTS)


def _task(spec: str, seed: int, index: int) -> tol.Task:
    return tol.Task(spec, _digest(spec), seed, index, INSTANTS)


def _strict(text: str):
    def refuse(name):
        raise ValueError(f"non-strict JSON constant {name}")
    return json.loads(text, parse_constant=refuse)


def test_zero_tolerances_give_the_compliance_answer(tmp_path):
    spec = _scene(tmp_path, "propshaft", "exact")
    _, op, _, _ = _nominal(spec)
    for form in tol.RUN:
        expected = tol.sample_loads(op, solve_over_time(op, form).forces)
        for index in (0, 1):
            sample = tol.run_sample(_task(spec, 7, index))
            assert sample["solved"][form] == INSTANTS
            for name, values in expected.items():
                assert sample["loads"][form][name] == pytest.approx(values, rel=1e-9, abs=1e-9)


@pytest.fixture(scope="module")
def seat(tmp_path_factory):
    """paper with seat offsets alone (+-50 um): its closed loop takes the misfit."""
    spec = _scene(tmp_path_factory.mktemp("seat"), "paper", "seat", seat=5e-5)
    scene, op, problems, sets = _nominal(spec)
    d = tol.misfit_vector(op, scene, tol.draws(scene, 3, 0)["seat"])
    return spec, op, problems, d


def test_a_misfit_moves_only_the_indeterminate_loads(seat):
    _, op, problems, d = seat
    for form in tol.RUN:
        nominal = solve_over_time(op, form, problem=problems[form].__getitem__).answers()
        moved = solve_over_time(op, form, problem=[tol.misfit_problem(
            p, op, d, None) for p in problems[form]].__getitem__).answers()
        for i in range(INSTANTS):
            x0, x = nominal[i], moved[i]
            scale = np.abs(x0).max()
            fixed = determinacy(op, i).determinate
            assert np.abs(x - x0)[fixed].max() < 1e-6 * scale
            assert np.abs(x - x0)[~fixed].max() > 1e-2 * scale  # the misfit does load it


def test_the_misfit_solve_is_the_least_energy_with_the_misfit_work(seat):
    """The linear compliance with a misfit equals an independent solve (cvxpy, CLARABEL,
    tight tolerances) of ``sum ||f||^2 / 2k - d.x`` on the same equations and end faces,
    to the solvers' accuracy, far closer than the misfit moves the loads."""
    cp = pytest.importorskip("cvxpy")
    _, op, problems, d = seat
    scene, n = op.scene, len(op.names)
    d_ref, n_exp = scene.contact.damping_full_depth_m, scene.contact.exponent
    references = []
    for i in range(INSTANTS):
        A, b = op.A[i], op.b[i]
        s = np.abs(b).max()
        z = cp.Variable(n)
        energy = sum(cp.sum_squares(z[list(law.columns)] * s) / (
            2 * law.stiffness * (d_ref ** (n_exp - 1) if law.hertz else 1.0))
            for law in contact_laws(op))
        cp.Problem(cp.Minimize((energy - s * (d @ z)) / s),
                   [A @ z == b / s, z[np.flatnonzero(op.unilateral)] >= 0]).solve(
            solver="CLARABEL", tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
        references.append(z.value * s)
    found = solve_over_time(op, "compliance", problem=lambda i: tol.misfit_problem(
        problems["compliance"][i], op, d, None)).answers()
    nominal = solve_over_time(op, "compliance").answers()
    for i, reference in enumerate(references):
        scale = np.abs(reference).max()
        assert np.abs(found[i] - reference).max() < 1e-4 * scale  # the solvers' accuracy
        assert np.abs(nominal[i] - reference).max() > 1e-2 * scale  # what the misfit moves


@pytest.mark.parametrize("effects", [None, ["gravity", "inertia", "clearance"]])
def test_every_sampled_load_lies_in_its_rigid_interval(tmp_path, effects):
    """Seat offsets and clearances keep ``A x = b``: no sampled component leaves the
    nominal rigid set (the gaps enter where the scene calls for clearance)."""
    spec = _scene(tmp_path, "paper", "spread", seat=5e-5, clearance=5e-6, effects=effects)
    for index in range(2):
        sample = tol.run_sample(_task(spec, 11, index))
        assert sample["solved"] == {form: INSTANTS for form in tol.RUN}
        assert sample["outside"] == {form: 0 for form in tol.RUN}


def test_a_bearing_pair_takes_sampled_clearances(tmp_path, capsys):
    """axle-pinion calls for clearance and its pinion's O pair is one cone in the conic
    compliance form: samples with seat offsets and clearances solve at every instant,
    stay in the rigid set, and the command's JSON is strict."""
    spec = _scene(tmp_path, "axle-pinion", "pair", seat=5e-5, clearance=5e-6)
    for index in range(2):
        sample = tol.run_sample(_task(spec, 5, index))
        assert sample["solved"] == {form: INSTANTS for form in tol.RUN}
        assert sample["outside"] == {form: 0 for form in tol.RUN}
        assert all(set(lives) >= {"pinion.tail", "pinion.head"}
                   for lives in sample["L10_Mrev"].values())
    assert main(["tolerances", "axle-pinion", "--samples", "2", "--instants", "2",
                 "--out", str(tmp_path / "json"), "--json", "--quiet"]) == 0
    assert _strict(capsys.readouterr().out)["stored"] == 2


def test_an_articulation_tolerance_moves_the_geometry(tmp_path):
    spec = _scene(tmp_path, "propshaft", "angles", angle=0.5)
    scene, op, _, _ = _nominal(spec)
    drawn = tol.draws(scene, 0, 0)
    assert np.all(np.abs(drawn["articulation"]) <= 0.5) and drawn["articulation"].any()
    moved = tol.sampled_operator(scene, op, drawn["articulation"])
    assert moved is not op and np.abs(moved.A - op.A).max() > 0


def test_the_store_resumes_without_loss_or_repeat(tmp_path):
    spec = _scene(tmp_path, "propshaft", "store", seat=1e-4)
    out = tmp_path / "out"
    first, lost = tol.run_study(spec, 3, 5, INSTANTS, out)
    assert not lost and first["stored"] == 3
    path = out / store.NAME
    text = path.read_text()
    last = text.splitlines()[-1]
    path.write_text(text + last + "\n" + last[: len(last) // 2])  # a repeat, a cut line
    again, lost = tol.run_study(spec, 4, 5, INSTANTS, out)
    assert not lost and again["stored"] == 4
    indices = [json.loads(line)["index"] for line in path.read_text().splitlines()[1:]]
    assert sorted(set(indices)) == [0, 1, 2, 3]
    fresh, _ = tol.run_study(spec, 4, 5, INSTANTS, tmp_path / "fresh")
    assert json.dumps(json_safe(again["L10_Mrev"])) == \
        json.dumps(json_safe(fresh["L10_Mrev"]))
    with images.styled():
        fig = tol.figure(again)
    assert images.print_problems(fig) == []  # the print rules
    with pytest.raises(store.StoreError):
        tol.run_study(spec, 4, 6, INSTANTS, out)  # another seed: another study


def test_tolerances_json_is_strict_and_bad_input_is_refused(tmp_path, capsys):
    out = str(tmp_path / "json")
    assert main(["tolerances", "propshaft", "--samples", "2", "--instants", "2",
                 "--out", out, "--json", "--quiet"]) == 0
    answer = _strict(capsys.readouterr().out)
    assert answer["stored"] == 2 and set(answer["loads"]) == set(tol.RUN)
    assert main(["tolerances", "propshaft", "--samples", "0"]) == 2
    assert main(["tolerances", "propshaft", "--samples", "100000", "--instants", "2001"]) == 2
    err = capsys.readouterr().err
    assert err.count("cardan: error:") == 2 and "Traceback" not in err


def test_dask_gives_the_local_samples(tmp_path):
    distributed = pytest.importorskip("distributed")
    spec = _scene(tmp_path, "propshaft", "dask", seat=1e-4, angle=0.1)
    here, _ = tol.run_study(spec, 3, 2, INSTANTS, tmp_path / "here")
    with distributed.LocalCluster(n_workers=1, processes=False, threads_per_worker=1,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster.scheduler_address) as client:
        there, lost = tol.run_study(spec, 3, 2, INSTANTS, tmp_path / "there", client)
    assert not lost
    assert json.dumps(json_safe(here["loads"])) == json.dumps(json_safe(there["loads"]))


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    """A store of two samples of a scene file with seat offsets: the spec and its text."""
    spec = _scene(tmp_path_factory.mktemp("stored"), "propshaft", "stored", seat=1e-4)
    out = tmp_path_factory.mktemp("stored-out")
    _, lost = tol.run_study(spec, 2, 1, INSTANTS, out)
    assert not lost
    return spec, (out / store.NAME).read_text()


def _run_into(spec: str, out, samples: int = 2) -> int:
    return main(["tolerances", spec, "--samples", str(samples), "--instants", str(INSTANTS),
                 "--seed", "1", "--out", str(out), "--quiet", "--json"])


def _first_load(sample: dict, form: str = "compliance") -> str:
    return next(iter(sample["loads"][form]))


CORRUPT = {
    "no loads": lambda s: s.pop("loads"),
    "loads one value short": lambda s: s["loads"]["compliance"].update(
        {_first_load(s): s["loads"]["compliance"][_first_load(s)][:-1]}),
    "a load value that is a list": lambda s: s["loads"]["compliance_hertz"][
        _first_load(s)].__setitem__(0, [1.0, 2.0]),
    "loads not a mapping": lambda s: s["loads"].update(compliance=[1.0, 2.0, 3.0]),
    "a load name missing": lambda s: s["loads"]["compliance"].pop(_first_load(s)),
    "a life that is text": lambda s: s["L10_Mrev"]["compliance"].update(
        {next(iter(s["L10_Mrev"]["compliance"])): "long"}),
    "solved not whole": lambda s: s["solved"].update(compliance=2.5),
    "solved past the instants": lambda s: s["solved"].update(compliance=INSTANTS + 1),
    "outside a boolean": lambda s: s["outside"].update(compliance=True),
    "a formulation missing": lambda s: s["outside"].pop("compliance_hertz"),
    "no index": lambda s: s.pop("index"),
    "an index that is text": lambda s: s.update(index="1"),
    "a negative index": lambda s: s.update(index=-1),
}


@pytest.mark.parametrize("corrupt", list(CORRUPT.values()) + ["[1, 2]", "{"],
                         ids=list(CORRUPT) + ["not an object", "not JSON"])
def test_a_corrupted_sample_line_is_one_line_naming_the_file_and_line(corrupt, stored,
                                                                      tmp_path, capsys):
    """Any part of a stored sample missing or of another type or shape: exit 2 with one
    line naming the file and the line, no traceback, and the store left as it was."""
    spec, text = stored
    head, first, second = text.splitlines()
    if callable(corrupt):
        sample = json.loads(second)
        corrupt(sample)
        second = json.dumps(sample)
    else:
        second = corrupt
    path = tmp_path / store.NAME
    path.write_text("\n".join([head, first, second]) + "\n")
    assert _run_into(spec, tmp_path) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith(f"cardan: error: {path}, line 3: ")
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err
    assert captured.out == "" and path.read_text() == "\n".join([head, first, second]) + "\n"


@pytest.mark.parametrize("head", ["[]", '{"study": 1}', '"samples"'])
def test_a_first_line_that_names_no_study_is_refused(head, stored, tmp_path, capsys):
    spec, text = stored
    path = tmp_path / store.NAME
    path.write_text(head + "\n" + "".join(text.splitlines(keepends=True)[1:]))
    assert _run_into(spec, tmp_path) == 2
    err = capsys.readouterr().err
    assert err == f"cardan: error: {path}, line 1: names no study; not a sample file, " \
        "choose another --out or remove it\n"


@pytest.mark.parametrize("content", ["", '{"study":{"scene":"sto'],
                         ids=["empty", "a first line cut short"])
def test_an_empty_store_is_a_new_store(content, stored, tmp_path, capsys):
    """An empty file (or one whose first line a kill cut short) holds no samples: the
    study runs into it, not refused as another study's."""
    spec, text = stored
    path = tmp_path / store.NAME
    path.write_text(content)
    assert _run_into(spec, tmp_path) == 0
    assert _strict(capsys.readouterr().out)["stored"] == 2
    assert path.read_text().splitlines()[0] == text.splitlines()[0]
    assert len(path.read_text().splitlines()) == 3


def _write_scene(path, *top: str, seat: float = 1e-4, tables: str = "") -> str:
    path.write_text("\n".join(['extends = "propshaft"', 'name = "edited"', *top,
                               "[tolerances]", f"bearing_seat_m = {seat!r}",
                               "articulation_deg = 0.0", "bearing_clearance_m = 0.0",
                               tables]) + "\n")
    return str(path)


@pytest.mark.parametrize("edit", [  # one kind of edit by default, the others in the slow job
    {"top": ["gravity_m_s2 = [0.0, 0.0, -9.0]"]},
    pytest.param({"seat": 2e-4}, marks=pytest.mark.slow),
    pytest.param({"tables": "[time]\nstart_s = 0.0\nstop_s = 0.5\nstep_s = 0.005"},
                 marks=pytest.mark.slow),
], ids=["a value outside the tolerances", "a tolerance", "the window"])
def test_an_edited_scene_is_another_study_and_an_unchanged_one_resumes(edit, tmp_path,
                                                                       capsys):
    """The store names the scene by its content: the same content at another path
    resumes; any edited value is refused in the same --out, with one line and the store
    untouched, and computed afresh elsewhere (not from what a process cached of the
    file before the edit)."""
    scene_file, out = tmp_path / "line.toml", tmp_path / "out"
    spec = _write_scene(scene_file)
    old_digest = _digest(spec)
    before, lost = tol.run_study(spec, 2, 1, INSTANTS, out)
    assert not lost
    moved = tmp_path / "elsewhere" / "line.toml"
    moved.parent.mkdir()
    moved.write_text(scene_file.read_text())
    assert _run_into(str(moved), out, samples=3) == 0  # the same study: resumed
    assert _strict(capsys.readouterr().out)["stored"] == 3
    kept = (out / store.NAME).read_text()
    assert len(kept.splitlines()) == 4
    _write_scene(scene_file, *edit.get("top", ()), seat=edit.get("seat", 1e-4),
                 tables=edit.get("tables", ""))
    assert _run_into(spec, out, samples=3) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"cardan: error: {out / store.NAME} holds another study (its "
                          "scene_sha256") and err.count("\n") == 1
    assert (out / store.NAME).read_text() == kept
    tol.nominal.cache_clear()  # a worker that never held the old scene reads the file
    with pytest.raises(ValueError, match="its content changed since the study started"):
        tol.run_sample(tol.Task(spec, old_digest, 1, 0, INSTANTS))
    after, lost = tol.run_study(spec, 2, 1, INSTANTS, tmp_path / "fresh")
    assert not lost and after["stored"] == 2
    assert json.dumps(json_safe(after)) != json.dumps(json_safe(before))
    if "tables" in edit:
        assert after["t_s"][-1] == pytest.approx(0.5)


@pytest.mark.parametrize("address", ["", "   "])
def test_an_empty_scheduler_address_is_refused(address, tmp_path, capsys):
    assert main(["tolerances", "propshaft", "--samples", "1", "--scheduler", address,
                 "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err == "cardan: error: --scheduler: the address is empty; give the scheduler's " \
        "(as tcp://HOST:PORT), or leave --scheduler out to run here\n"
    assert not (tmp_path / store.NAME).exists()


def test_a_dask_study_whose_workers_all_die_ends_at_the_timeout(tmp_path, monkeypatch,
                                                                capsys):
    """Every worker closed once the first sample is stored: the study ends about
    --timeout s later with exit 1, the reason on stderr even with --quiet, the samples
    stored kept; a rerun here computes only the others."""
    distributed = pytest.importorskip("distributed")
    spec = _scene(tmp_path, "propshaft", "dies", seat=1e-4)
    out = tmp_path / "out"
    append = store.append
    with distributed.LocalCluster(n_workers=1, processes=False, threads_per_worker=1,
                                  dashboard_address=None) as cluster:
        def append_then_close_workers(f, sample):
            append(f, sample)
            for worker in list(cluster.workers.values()):
                cluster.sync(worker.close, executor_wait=False)

        monkeypatch.setattr(store, "append", append_then_close_workers)
        started = time.monotonic()
        code = main(["tolerances", spec, "--samples", "6", "--instants", str(INSTANTS),
                     "--seed", "1", "--out", str(out), "--scheduler", cluster.scheduler_address,
                     "--timeout", "1", "--quiet", "--json"])
        took = time.monotonic() - started
    monkeypatch.setattr(store, "append", append)
    captured = capsys.readouterr()
    assert code == 1 and took < 20
    stored_now = _strict(captured.out)["stored"]
    assert 1 <= stored_now < 6
    assert re.search(rf"tolerances: lost {6 - stored_now} sample\(s\): NoWorkers: the Dask "
                     r"scheduler at \S+ has had no worker for 1 s \(--timeout\)", captured.err)
    assert len((out / store.NAME).read_text().splitlines()) == 1 + stored_now
    assert _run_into(spec, out, samples=6) == 0
    assert _strict(capsys.readouterr().out)["stored"] == 6


def test_the_report_states_the_tolerance_of_its_inside_rule():
    """The rule that counts a sampled load outside the set is relative to the loads,
    and the report says by how much."""
    from types import SimpleNamespace

    forces = np.array([[100.0, 0.0], [1000.0, 0.0]])
    sets = SimpleNamespace(min=np.zeros((2, 2)), max=np.array([[100.0 - 5e-4, 0.0],
                                                               [1000.0 - 5e-3, 0.0]]))
    assert tol.outside(forces, sets) == 0  # 5e-6 of each instant's load
    assert tol.outside(forces * (1 + 2 * tol.INSIDE_RTOL), sets) == 2
    answer = {"scene": "s", "stored": 1, "samples": 1, "instants": 1, "tolerances": {},
              "notes": [], "solved": dict.fromkeys(tol.RUN, 1),
              "outside": dict.fromkeys(tol.RUN, 0), "L10_Mrev": dict.fromkeys(tol.RUN, {})}
    assert f"by more than {tol.INSIDE_RTOL:g} of the instant's largest load" in \
        tol.markdown(answer)
