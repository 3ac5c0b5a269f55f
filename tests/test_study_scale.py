"""Studies at scale (issue #19): cases made on demand, chunks never held together, the
table written from the chunk files one at a time, the report of a large table streamed.

These test the mechanism (what is never materialized, what is read), not timings or
memory figures (``benchmarks/bench_study.py --memory`` measures those).
"""

from __future__ import annotations

import itertools
import json

import numpy as np
import pandas as pd
import pytest

from roverimpact.report import html as report_html
from roverimpact.report import summary as report_summary
from roverimpact.studies import FunctionEvaluator, run_study, sweep
from roverimpact.studies.config import CaseSequence, case_id, cases_of, study_from_dict
from roverimpact.studies.store import chunk_path

BASE = {
    "model": {"name": "rigid_body",
              "params": {"mass": 20.0, "inertia": 1.2, "com_height": 0.3, "lever": 0.4}},
    "velocity": {"u": 0.5},
    "obstacle": {"frame": "contact", "beta_deg": 90.0},
}


def test_grid_cases_on_demand_are_the_product_in_order():
    """Independent reference: itertools.product (first key slowest), ids hashed alike."""
    grid = {"obstacle.beta_deg": [10.0, 20.0, 30.0], "velocity.u": [0.1, 0.2],
            "model.params.com_height": [0.2, 0.3, 0.4, 0.5]}
    seq = cases_of(study_from_dict({"name": "g", "base": BASE, "grid": grid}))
    ref = list(itertools.product(*grid.values()))
    assert len(seq) == len(ref) == 24
    for i, vals in enumerate(ref):
        ov = dict(zip(grid, vals, strict=True))
        c = seq[i]
        assert (c.index, c.overrides, c.case_id) == (i, ov, case_id(i, ov))
    assert [c.index for c in seq[5:11]] == list(range(5, 11))
    assert seq[-1].index == 23 and [c.index for c in seq[::7]] == [0, 7, 14, 21]
    with pytest.raises(IndexError):
        seq[24]


def test_random_cases_on_demand_draw_as_before():
    """Reference: the draws of numpy's default_rng in parameter order, as lists."""
    params = {"obstacle.beta_deg": {"low": 0.0, "high": 60.0},
              "velocity.u": {"choices": [0.2, 0.4, "x"]},
              "model.params.com_height": {"low": 0.1, "high": 0.5}}
    seq = cases_of(study_from_dict({"name": "r", "base": BASE, "random": {
        "n": 50, "seed": 7, "params": params}}))
    rng = np.random.default_rng(7)
    beta = list(rng.uniform(0.0, 60.0, 50))
    u = [[0.2, 0.4, "x"][i] for i in rng.integers(0, 3, 50)]
    h = list(rng.uniform(0.1, 0.5, 50))
    got = [c.overrides for c in seq]
    assert got == [{"obstacle.beta_deg": float(a), "velocity.u": b,
                    "model.params.com_height": float(c)} for a, b, c in zip(beta, u, h,
                                                                             strict=True)]


@pytest.mark.parametrize("design", ["grid", "random"])
def test_iterated_cases_are_the_cases_one_by_one(design, monkeypatch):
    """Iterating a design makes its cases in blocks (values a column at a time, the id's
    text written out): the same cases, values and ids as :meth:`CaseSequence.case` and
    :func:`case_id`, across blocks, in views with an offset and for every value type."""
    from roverimpact.studies import config

    monkeypatch.setattr(config, "_ITER_BLOCK", 7)  # several blocks, one shorter
    if design == "grid":
        spec = {"grid": {"obstacle.beta_deg": [10.0, 1e-7, 90], "velocity.u": [0.1, 2],
                         "contact_law.name": ["hertz", "hunt-crossley"],
                         "model.params.com_height": {"start": 0.2, "stop": 0.5, "num": 3},
                         "simulation.record": [True, False]}}
    else:
        spec = {"random": {"n": 40, "seed": 3, "params": {
            "obstacle.beta_deg": {"low": 0.0, "high": 60.0},
            "velocity.u": {"choices": [0.2, 4, "x", True]},
            "model.params.com_height": {"low": 0.1, "high": 0.5}}}}
    seq = cases_of(study_from_dict({"name": "it", "base": BASE, **spec}))
    for s in (seq, seq.view(5, 31), seq.view(30, 30)):
        got = list(s)
        assert len(got) == len(s)
        for i, c in enumerate(got):
            ref = s.case(i)
            assert (c.index, c.case_id, c.overrides) == (ref.index, ref.case_id, ref.overrides)
            assert list(c.overrides) == list(ref.overrides)  # the same key order
            assert [type(v) for v in c.overrides.values()] == \
                [type(v) for v in ref.overrides.values()]
            assert c.case_id == case_id(c.index, c.overrides)


def _tc(scn):
    beta = np.deg2rad(scn["obstacle"]["beta_deg"])
    h = scn["model"]["params"]["com_height"]
    v = scn["velocity"]["u"] * np.sin(beta)
    return {"T_c_minus": 0.5 * 20.0 * v * v * (1 + h), "v_n": v,
            "F_max": 1e3 * v * (1 + h) ** 2 + 3.0 * np.cos(7 * beta)}


EV = FunctionEvaluator(_tc, name="closed_form")


def test_run_study_never_holds_all_cases_or_the_table(tmp_path, monkeypatch):
    """No full list of cases, at most one chunk of cases at a time, the table never
    concatenated nor read back; the written table is the chunks in order."""
    made = []
    real_getitem, real_iter = CaseSequence.__getitem__, CaseSequence.__iter__

    def getitem(self, key):
        out = real_getitem(self, key)
        made.append(len(out) if isinstance(out, list) else 1)
        return out

    def iterate(self):
        # a chunk's view is iterated where its chunk is computed; the study's sequence never
        made.append(len(self))
        if len(self) == 51:
            pytest.fail("all cases made")
        return real_iter(self)

    monkeypatch.setattr(CaseSequence, "__getitem__", getitem)
    monkeypatch.setattr(CaseSequence, "__iter__", iterate)
    monkeypatch.setattr(sweep, "expand", lambda *a: pytest.fail("expand called"),
                        raising=False)
    monkeypatch.setattr(pd, "concat", lambda *a, **k: pytest.fail("table concatenated"))
    monkeypatch.setattr(pd, "read_parquet", lambda *a, **k: pytest.fail("table read"))
    study = {"name": "s", "base": BASE, "grid": {
        "obstacle.beta_deg": {"start": 10, "stop": 90, "num": 17},
        "model.params.com_height": [0.2, 0.3, 0.45]}}
    res = run_study(study, tmp_path / "r", evaluator=EV, chunk_size=5, csv=True)
    assert res.n_cases == 51 and res.n_computed == 51
    assert made and max(made) <= 5  # one chunk of cases at a time
    monkeypatch.undo()
    chunks = [pd.read_parquet(chunk_path(tmp_path / "r", k)) for k in range(11)]
    ref = pd.concat(chunks, ignore_index=True)
    pd.testing.assert_frame_equal(res.table, ref)
    assert res.table["case"].tolist() == list(range(51))
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "r" / "results.csv"),
                                  pd.read_csv(pd.io.common.StringIO(ref.to_csv(index=False))))


def test_chunks_of_mixed_types_fall_back_to_the_in_memory_table(tmp_path):
    """A parameter column int in one chunk and float in another: unified as before."""
    study = {"name": "m", "base": BASE, "cases": [
        {"velocity.u": 1}, {"velocity.u": 1}, {"velocity.u": 0.5}, {"velocity.u": 0.7}]}
    res = run_study(study, tmp_path / "m", evaluator=EV, chunk_size=2)
    assert res.table["velocity.u"].tolist() == [1.0, 1.0, 0.5, 0.7]
    assert res.table["velocity.u"].dtype == float


def _chunked_study(tmp_path, cases, chunk_size):
    study = {"name": "st", "base": BASE, "cases": cases}
    res = run_study(study, tmp_path / "ref", evaluator=EV, chunk_size=chunk_size, csv=True)
    return study, res


def test_results_stream_writes_the_table_as_chunks_arrive(tmp_path):
    """The table written while the chunks arrive (out of order; the stream waits for the
    first one not ready, and never reads a file not marked ready) is the table written at
    the end, and so is its CSV."""
    from roverimpact.studies.store import RESULTS, ResultsStream, write_results
    from roverimpact.studies.sweep import Chunks

    cases = [{"obstacle.beta_deg": float(b)} for b in range(5, 90, 7)]
    study, ref = _chunked_study(tmp_path, cases, 3)
    chunks = Chunks(cases_of(study_from_dict(study)), 3)
    out = tmp_path / "stream"
    (out / "chunks").mkdir(parents=True)
    # chunk 1: a damaged file of an earlier run, there but not ready (being recomputed)
    chunk_path(out, 1).write_bytes(b"not parquet")
    # chunk 3: finished by an earlier run
    chunk_path(out, 3).write_bytes(chunk_path(tmp_path / "ref", 3).read_bytes())
    stream = ResultsStream(out, chunks, out / RESULTS, done={3})
    order = [2, 0, 4, 1]  # chunk 0 after 2: nothing written before it comes
    written = []
    for k in order:
        chunk_path(out, k).write_bytes(chunk_path(tmp_path / "ref", k).read_bytes())
        stream.ready(k)
        written.append(stream.n_rows)
    assert written == [0, 3, 3, 13] and len(cases) == 13
    assert len(list(out.glob(".*.tmp"))) == 1  # the table so far, not yet in place
    n = write_results(out, chunks, out / RESULTS, csv=out / "results.csv", stream=stream)
    assert n == 13 and not list(out.glob(".*.tmp"))
    pd.testing.assert_frame_equal(pd.read_parquet(out / RESULTS), ref.table)
    assert (out / "results.csv").read_text() == (tmp_path / "ref" / "results.csv").read_text()


def test_results_table_sorts_a_chunk_written_out_of_order(tmp_path):
    """A chunk file whose rows are not in case order (another writer) goes into the table
    in case order; the table is the one of the ordered chunks."""
    from roverimpact.studies.store import RESULTS, write_results
    from roverimpact.studies.sweep import Chunks

    cases = [{"obstacle.beta_deg": float(b)} for b in range(5, 90, 7)]
    study, ref = _chunked_study(tmp_path, cases, 3)
    chunks = Chunks(cases_of(study_from_dict(study)), 3)
    out = tmp_path / "shuffled"
    (out / "chunks").mkdir(parents=True)
    for k in range(len(chunks)):
        df = pd.read_parquet(chunk_path(tmp_path / "ref", k))
        (df.iloc[::-1] if k in (1, 4) else df).to_parquet(chunk_path(out, k), index=False)
    assert pd.read_parquet(chunk_path(out, 1))["case"].tolist() == [5, 4, 3]
    assert write_results(out, chunks, out / RESULTS) == 13
    pd.testing.assert_frame_equal(pd.read_parquet(out / RESULTS), ref.table)


def test_results_stream_stops_at_another_column_type_and_leaves_nothing(tmp_path):
    """Chunks whose columns differ in type (an int, then a float parameter) stop the
    stream; the table is then written as without it (unified), and an abandoned stream
    leaves no file behind."""
    from roverimpact.studies.store import RESULTS, ResultsStream, write_results
    from roverimpact.studies.sweep import Chunks

    cases = [{"velocity.u": 1}, {"velocity.u": 1}, {"velocity.u": 0.5}, {"velocity.u": 0.7}]
    study, _ = _chunked_study(tmp_path, cases, 2)
    chunks = Chunks(cases_of(study_from_dict(study)), 2)
    stream = ResultsStream(tmp_path / "ref", chunks, tmp_path / "ref" / "again.parquet",
                           done={0, 1})
    stream.advance()
    assert stream.n_rows == 2  # chunk 0 written; chunk 1 has a float column: stopped
    assert stream.finish() is None and not list((tmp_path / "ref").glob(".*.tmp"))
    n = write_results(tmp_path / "ref", chunks, tmp_path / "ref" / RESULTS,
                      stream=ResultsStream(tmp_path / "ref", chunks, tmp_path / "x.parquet"))
    assert n == 4 and pd.read_parquet(tmp_path / "ref" / RESULTS)["velocity.u"].tolist() == \
        [1.0, 1.0, 0.5, 0.7]
    assert not (tmp_path / "x.parquet").exists()
    half = ResultsStream(tmp_path / "ref", chunks, tmp_path / "y.parquet", done={0})
    half.advance()
    assert half.n_rows == 2
    half.abandon()
    assert not list(tmp_path.glob(".*.tmp")) and not (tmp_path / "y.parquet").exists()


def test_large_report_streams_and_matches_the_full_path(tmp_path, monkeypatch):
    """Above LARGE_TABLE rows the report reads the table in batches; with a sample that
    holds every row, its statistics are those of the full path, and its per-bin
    aggregates are those of pandas on the whole table."""
    study = {"name": "big", "base": BASE, "random": {"n": 300, "seed": 2, "params": {
        "obstacle.beta_deg": {"low": 5.0, "high": 85.0},
        "model.params.com_height": {"low": 0.1, "high": 0.6}}}}
    res = run_study(study, tmp_path / "b", evaluator=EV, chunk_size=64)
    full = report_html.analyse_folder(tmp_path / "b", n_boot=100)
    monkeypatch.setattr(report_html, "LARGE_TABLE", 100)
    monkeypatch.setattr(report_summary, "SAMPLE_ROWS", 1000)
    monkeypatch.setattr(report_summary, "BATCH", 37)
    monkeypatch.setattr(pd, "read_parquet", lambda *a, **k: pytest.fail("table read whole"))
    big = report_html.analyse_folder(tmp_path / "b", n_boot=100)
    monkeypatch.undo()
    assert big.n_rows == 300 and big.n_cases == 300 and len(big.head) == 200
    assert big.agreement.spearman.value == pytest.approx(full.agreement.spearman.value,
                                                         abs=1e-12)
    assert big.agreement.spearman.low == pytest.approx(full.agreement.spearman.low, abs=1e-12)
    stats = json.loads((tmp_path / "b" / "stats.json").read_text())
    assert stats["sample"] == {"n_cases": 300, "n_sample": 300, "seed": 0}
    assert (tmp_path / "b" / "figure.png").is_file() and "sample" in big.note
    # per-bin aggregates against pandas on the whole table
    t = res.table
    s = report_summary.summarize(tmp_path / "b" / "results.parquet", "obstacle.beta_deg",
                                 ["T_c_minus", "F_max"], binned=["T_c_minus", "F_max"],
                                 n_bins=8, batch=50)
    x = t["obstacle.beta_deg"].to_numpy()
    b = np.clip(((x - x.min()) / (x.max() - x.min()) * 8).astype(int), 0, 7)
    for col in ("T_c_minus", "F_max"):
        g = t.groupby(b)[col]
        st = s.bins.columns[col]
        np.testing.assert_array_equal(st.count, g.count().reindex(range(8)).to_numpy())
        np.testing.assert_allclose(st.mean, g.mean().reindex(range(8)).to_numpy(), rtol=1e-12)
        np.testing.assert_array_equal(st.min, g.min().reindex(range(8)).to_numpy())
        np.testing.assert_array_equal(st.max, g.max().reindex(range(8)).to_numpy())
        width = st.y_edges[1] - st.y_edges[0]
        for q in (0.05, 0.5, 0.95):
            ref = g.quantile(q, interpolation="lower").reindex(range(8)).to_numpy()
            ref_hi = g.quantile(q, interpolation="higher").reindex(range(8)).to_numpy()
            got = st.quantile(q)
            assert np.all((got >= ref - width - 1e-12) & (got <= ref_hi + width + 1e-12))


def test_large_report_sample_is_bounded_and_seeded(tmp_path, monkeypatch):
    study = {"name": "big", "base": BASE, "random": {"n": 400, "seed": 4, "params": {
        "obstacle.beta_deg": {"low": 5.0, "high": 85.0}}}}
    run_study(study, tmp_path / "b", evaluator=EV)
    path = tmp_path / "b" / "results.parquet"
    a = report_summary.summarize(path, "obstacle.beta_deg", ["T_c_minus"], binned=[],
                                 sample_rows=50, seed=1, batch=64)
    b = report_summary.summarize(path, "obstacle.beta_deg", ["T_c_minus"], binned=[],
                                 sample_rows=50, seed=1, batch=17)
    c = report_summary.summarize(path, "obstacle.beta_deg", ["T_c_minus"], binned=[],
                                 sample_rows=50, seed=2, batch=64)
    assert len(a.sample) == 50 and a.sample["case"].is_unique
    pd.testing.assert_frame_equal(a.sample, b.sample)  # same rows whatever the batches
    assert set(a.sample["case"]) != set(c.sample["case"])
    full = pd.read_parquet(path).set_index("case").loc[a.sample["case"], "T_c_minus"]
    np.testing.assert_array_equal(full.to_numpy(), a.sample["T_c_minus"].to_numpy())


ROVER = {
    "model": {"name": "rocker_bogie", "preset": "prototype"},
    "velocity": {"u": 0.3},
    "contacts": {"ground": "normal"},
    "obstacle": {"wheel": "left_front", "beta_deg": 60.0},
    "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 1.0},
}


def test_model_changing_cases_match_a_fresh_build_per_case(monkeypatch):
    """Every case changes the model (random COM height, chassis mass, speed, angle), a
    few share a model (a beta sweep within the chunk; other speeds): the evaluator's
    outputs equal one evaluate_case (fresh scenario, model and setup) per case to 1e-12.
    The cases of their own are one block of the model family: one model built for them
    all (scenario.block), one for the beta sweep."""
    from roverimpact.studies import ScenarioEvaluator, evaluate_case
    from roverimpact.studies.config import apply_overrides

    study = study_from_dict({"name": "r", "base": ROVER, "random": {"n": 12, "seed": 5,
        "params": {"obstacle.beta_deg": {"low": 10.0, "high": 90.0},
                   "model.params.chassis_com_above_pivot": {"low": 0.02, "high": 0.2},
                   "model.params.chassis_mass": {"low": 10.0, "high": 20.0},
                   "velocity.u": {"low": 0.1, "high": 0.5}}}})
    overrides = [c.overrides for c in cases_of(study)]
    shared = {k: v for k, v in overrides[0].items() if k != "obstacle.beta_deg"}
    overrides += [shared | {"obstacle.beta_deg": b} for b in (15.0, 45.0, 80.0)]
    # the same model at other speeds and angles: groups of their own, one built model
    overrides += [shared | {"velocity.u": u, "obstacle.beta_deg": b}
                  for u, b in ((0.15, 20.0), (0.45, 70.0), (0.3, 33.0))]
    from roverimpact.scenario import build

    built = []  # every model built goes through make_model
    real = build.make_model
    monkeypatch.setattr(build, "make_model", lambda *a, **k: built.append(1) or real(*a, **k))
    got = ScenarioEvaluator().evaluate(ROVER, overrides)
    monkeypatch.undo()
    assert len(built) == 2  # one model for the block, one for the beta sweep
    for i, ov in enumerate(overrides):
        ref = evaluate_case(apply_overrides(ROVER, ov))
        for col in ("T_c_minus", "m_eff", "v_n", "F_pred", "m_total", "m_eff_free",
                    "T_n_total", "T_c_obstacle"):
            assert got[col][i] == pytest.approx(ref[col], rel=1e-12, abs=1e-15), (i, col)
    assert len(set(np.round(got["m_total"], 9))) > 10  # the model did change


def test_model_changing_cases_made_from_their_numbers_are_their_scenarios(monkeypatch):
    """After the first case of a model family, a case is made from its numbers, not a
    scenario of its own: ints, floats, numpy floats and a parameter the first case set
    give the outputs of a validated scenario per case; a bad case (an angle above 90
    degrees, a parameter the model refuses) gives the error its own scenario gives."""
    from roverimpact.exceptions import RoverImpactError
    from roverimpact.studies import ScenarioEvaluator, evaluate_case
    from roverimpact.studies.config import apply_overrides

    p = "model.params."
    overrides = [{p + "chassis_mass": 12.0, "velocity.u": 0.2, "obstacle.beta_deg": 30.0},
                 {p + "chassis_mass": 15, "velocity.u": 1, "obstacle.beta_deg": 90},
                 {p + "chassis_mass": np.float64(11.5), "velocity.u": np.float64(0.35),
                  "obstacle.beta_deg": 0.0},
                 {p + "chassis_mass": 13.0, "velocity.u": 0.3, "obstacle.beta_deg": 45.0,
                  p + "chassis_com_above_pivot": 0.15},
                 {p + "chassis_mass": 14.0, "velocity.u": 0.25, "obstacle.beta_deg": 60.0,
                  p + "chassis_com_above_pivot": 0.05}]
    from roverimpact.studies import evaluate

    validated = []
    real = evaluate.scenario_from_dict
    monkeypatch.setattr(evaluate, "scenario_from_dict",
                        lambda raw: validated.append(raw) or real(raw))
    got = ScenarioEvaluator().evaluate(ROVER, overrides)
    monkeypatch.undo()
    assert len(validated) == 3  # the first case of each family, and the contact law
    for i, ov in enumerate(overrides):
        ref = evaluate_case(apply_overrides(ROVER, ov))
        for col in ("T_c_minus", "m_eff", "v_n", "m_total", "m_eff_free"):
            assert got[col][i] == pytest.approx(ref[col], rel=1e-12, abs=1e-15), (i, col)
    for bad in ({p + "chassis_mass": 12.5, "velocity.u": 0.2, "obstacle.beta_deg": 95.0},
                {p + "chassis_mass": -3.0, "velocity.u": 0.2, "obstacle.beta_deg": 30.0}):
        with pytest.raises(RoverImpactError) as own:
            evaluate_case(apply_overrides(ROVER, bad))
        with pytest.raises(RoverImpactError) as in_block:
            ScenarioEvaluator().evaluate(ROVER, [overrides[0], bad, overrides[2]])
        assert str(in_block.value) == str(own.value)


@pytest.mark.parametrize("design", [
    {"grid": {"obstacle.beta_deg": {"start": 10, "stop": 90, "num": 17},
              "model.params.com_height": [0.2, 0.3, 0.45]}},
    {"random": {"n": 40, "seed": 3, "params": {"obstacle.beta_deg": {"low": 10, "high": 90},
                                               "velocity.u": {"choices": [0.1, 0.3]}}}},
    {"cases": [{"velocity.u": 0.1}, {"obstacle.beta_deg": 30.0}, {"velocity.u": 0.2}] * 5},
])
def test_chunk_views_are_the_cases_and_small_to_ship(design):
    """A chunk is a view of the study's cases (what run_study ships to a Dask worker):
    the same cases, indices and ids as the full expansion, and its pickle does not grow
    with the study (a grid's axes, or the slice of the drawn values)."""
    import pickle

    study = study_from_dict({"name": "v", "base": BASE, **design})
    seq = cases_of(study)
    full = list(seq)
    for size in (1, 4, 7, len(full) + 3):
        chunks = sweep.Chunks(seq, size)
        got = [c for k in range(len(chunks)) for c in chunks[k]]
        assert got == full
        assert all(len(chunks[k]) == chunks.n_cases(k) for k in range(len(chunks)))
    view = seq.view(3, 5)
    assert list(view) == full[3:5] and view[1] == full[4] and list(view.view(1, 2)) == full[4:5]
    if "cases" not in design:
        assert len(pickle.dumps(seq.view(0, 2))) < 2000


def test_case_keys_group_cases_that_share_the_setup_and_the_law():
    """Group key: the overrides but beta, the contact law and the simulation settings
    (their repr, so 1 and 1.0 stay apart); law key: the contact-law overrides. Keys of
    cases with different override names never collide."""
    from roverimpact.studies.evaluate import _CaseKeys

    def ref(ov):
        g = sorted((k, v) for k, v in ov.items() if k != "obstacle.beta_deg"
                   and not k.startswith(("contact_law.", "simulation.")))
        law = sorted((k, v) for k, v in ov.items() if k.startswith("contact_law."))
        return repr(g), repr(law)

    keys = _CaseKeys()
    cases = [{"obstacle.beta_deg": b, "velocity.u": u, "contact_law.k": k,
              "simulation.t_after": 0.1}
             for b in (10.0, 20.0) for u in (1, 1.0, 0.5) for k in (1e6, 1e7)]
    cases += [{"contact_law.name": "hertz"}, {}, {"model.params.x": [1, 2]},
              {"velocity.u": 1.0, "obstacle.beta_deg": 10.0}]
    got = [keys(ov) for ov in cases]
    assert got == [ref(ov) for ov in cases]
    assert got[0][0] != got[2][0]  # u = 1 and u = 1.0: two groups
    assert got[0][0] == got[6][0] and got[0][1] != got[1][1]  # beta apart, k apart


def test_automatic_chunks_are_large_where_cases_are_cheap():
    """Indicator-only cases of tens of microseconds (an angle sweep of one model, a
    built-in model's family numbers) come in chunks of at least CHEAP_AUTO_CHUNK; cases
    built one by one (a rover on a terrain, a function of one's own) in
    chunks of at least MIN_AUTO_CHUNK, so that the progress bar moves; simulated cases in
    about 100 chunks; above 20 * CHEAP_AUTO_CHUNK cases, about 20 chunks."""
    from roverimpact.studies.sweep import CHEAP_AUTO_CHUNK, MIN_AUTO_CHUNK, prepare_study

    rover = {"model": {"name": "rover2d"}, "velocity": {"u": 0.3},
             "obstacle": {"wheel": "front", "beta_deg": 45.0}}
    on_terrain = {**rover, "terrain": {"plane": {"normal": [-0.17, 0.0, 0.98]}}}
    angles = {"obstacle.beta_deg": {"start": 1.0, "stop": 90.0, "num": 3000}}
    numbers = {"model.params.h": {"start": 0.3, "stop": 0.5, "num": 30},
               "velocity.u": [0.2, 0.4], **{k: {**v, "num": 50} for k, v in angles.items()}}

    def chunk(base, grid, **kw):
        return prepare_study({"name": "c", "base": base, "grid": grid, **kw}).chunk_size

    assert chunk(rover, angles) == chunk(on_terrain, angles) == CHEAP_AUTO_CHUNK
    assert chunk(rover, numbers) == chunk(BASE, angles) == CHEAP_AUTO_CHUNK
    assert chunk(on_terrain, numbers) == MIN_AUTO_CHUNK  # each case its own terrain pose
    assert chunk(BASE, {"model.params.mass": [10.0 + i for i in range(3000)]}) == \
        CHEAP_AUTO_CHUNK  # the rigid body's family numbers
    assert chunk(rover, {"contacts.ground": ["normal", "noslip"],
                         "obstacle.beta_deg": [10.0, 30.0]}) == MIN_AUTO_CHUNK
    assert prepare_study({"name": "f", "base": BASE, "grid": angles},
                         evaluator=EV).chunk_size == MIN_AUTO_CHUNK
    assert chunk(rover, angles, simulate=True) == 30
    big = {"obstacle.beta_deg": {"start": 1.0, "stop": 90.0, "num": 100_000}}
    assert chunk(rover, big) == 5_000
    assert chunk(on_terrain, {"model.params.h": [0.3, 0.4], **big}) == 10_000
