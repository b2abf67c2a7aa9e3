"""The tolerance study (``cardan tolerances``): zero tolerances give the compliance
answer, a seat misfit moves only the indeterminate loads and equals an independent
solve of the same energy, sampled loads stay in the rigid set, the store resumes
without losing or repeating a sample, the JSON is strict."""

import json

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.experiments import tolerance_store as store
from cardan_forces.experiments import tolerances as tol
from cardan_forces.experiments.environment import json_safe
from cardan_forces.experiments.images import problems
from cardan_forces.experiments.study import solve_over_time
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


def _strict(text: str):
    def refuse(name):
        raise ValueError(f"non-strict JSON constant {name}")
    return json.loads(text, parse_constant=refuse)


def test_zero_tolerances_give_the_compliance_answer(tmp_path):
    spec = _scene(tmp_path, "propshaft", "exact")
    _, op, _, _ = tol.nominal(spec, INSTANTS)
    for form in tol.RUN:
        expected = tol.sample_loads(op, solve_over_time(op, form).forces)
        for index in (0, 1):
            sample = tol.run_sample(tol.Task(spec, 7, index, INSTANTS))
            assert sample["solved"][form] == INSTANTS
            for name, values in expected.items():
                assert sample["loads"][form][name] == pytest.approx(values, rel=1e-9, abs=1e-9)


@pytest.fixture(scope="module")
def seat(tmp_path_factory):
    """paper with seat offsets alone (+-50 um): its closed loop takes the misfit."""
    spec = _scene(tmp_path_factory.mktemp("seat"), "paper", "seat", seat=5e-5)
    scene, op, problems, sets = tol.nominal(spec, INSTANTS)
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
        sample = tol.run_sample(tol.Task(spec, 11, index, INSTANTS))
        assert sample["solved"] == {form: INSTANTS for form in tol.RUN}
        assert sample["outside"] == {form: 0 for form in tol.RUN}


def test_a_bearing_pair_takes_sampled_clearances(tmp_path, capsys):
    """axle-pinion calls for clearance and its pinion's O pair is one cone in the conic
    compliance form: samples with seat offsets and clearances solve at every instant,
    stay in the rigid set, and the command's JSON is strict."""
    spec = _scene(tmp_path, "axle-pinion", "pair", seat=5e-5, clearance=5e-6)
    for index in range(2):
        sample = tol.run_sample(tol.Task(spec, 5, index, INSTANTS))
        assert sample["solved"] == {form: INSTANTS for form in tol.RUN}
        assert sample["outside"] == {form: 0 for form in tol.RUN}
        assert all(set(lives) >= {"pinion.tail", "pinion.head"}
                   for lives in sample["L10_Mrev"].values())
    assert main(["tolerances", "axle-pinion", "--samples", "2", "--instants", "2",
                 "--out", str(tmp_path / "json"), "--json", "--quiet"]) == 0
    assert _strict(capsys.readouterr().out)["stored"] == 2


def test_an_articulation_tolerance_moves_the_geometry(tmp_path):
    spec = _scene(tmp_path, "propshaft", "angles", angle=0.5)
    scene, op, _, _ = tol.nominal(spec, INSTANTS)
    drawn = tol.draws(scene, 0, 0)
    assert np.all(np.abs(drawn["articulation"]) <= 0.5) and drawn["articulation"].any()
    moved = tol.sampled_operator(scene, op, drawn["articulation"])
    assert moved is not op and np.abs(moved.A - op.A).max() > 0


def test_the_store_resumes_without_loss_or_repeat(tmp_path):
    spec = _scene(tmp_path, "propshaft", "store", seat=1e-4)
    out = tmp_path / "out"
    first, lost = tol.run_study(spec, 3, 5, INSTANTS, out)
    assert lost == 0 and first["stored"] == 3
    path = out / store.NAME
    text = path.read_text()
    last = text.splitlines()[-1]
    path.write_text(text + last + "\n" + last[: len(last) // 2])  # a repeat, a cut line
    again, lost = tol.run_study(spec, 4, 5, INSTANTS, out)
    assert lost == 0 and again["stored"] == 4
    indices = [json.loads(line)["index"] for line in path.read_text().splitlines()[1:]]
    assert sorted(set(indices)) == [0, 1, 2, 3]
    fresh, _ = tol.run_study(spec, 4, 5, INSTANTS, tmp_path / "fresh")
    assert json.dumps(json_safe(again["L10_Mrev"])) == \
        json.dumps(json_safe(fresh["L10_Mrev"]))
    assert not problems(tol.figure(again))  # the print rules
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
    assert lost == 0
    assert json.dumps(json_safe(here["loads"])) == json.dumps(json_safe(there["loads"]))
