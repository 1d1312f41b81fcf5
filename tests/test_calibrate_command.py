"""Calibrating real-rig recordings: CSV in, estimators that know what they were fitted on,
their uncertainty, the command line, the scikit-learn face, and the estimator in C."""

import dataclasses
import json
import shutil
import warnings

import numpy as np
import pytest

from calibrate import splits, __main__ as cli
from calibrate.cli import evaluate as evaluate_cli
from calibrate import cexport, csvfile, estimators, metrics
from calibrate.parts import mlp
from calibrate.sklearn_api import ForceCalibrator
from util import errors

FAST = mlp.LMConfig(hidden=6, epochs=8)


def _data(n=1500, seed=0):
  rng = np.random.default_rng(seed)
  counts = rng.integers(500, 3600, (n, 6)).astype(float)
  z = (counts - 2000) / 800
  forces = np.column_stack([z[:, 0] - z[:, 1] + 0.3 * z[:, 0] ** 2, z[:, 2] - z[:, 3],
                            40 + 10 * z.sum(axis=1) + np.tanh(z[:, 4])])
  return counts, forces + 0.01 * rng.normal(size=forces.shape)


# ---- the CSV layout ----------------------------------------------------------------------

def _csv(tmp_path, text, name="rec.csv"):
  path = tmp_path / name
  path.write_text(text)
  return path


@pytest.mark.parametrize("body, where", [
    ("time,p1,Fx\ns,counts,N\n0,1,2\n0.1,,3\n", "line 4, column 'p1': is empty"),
    ("time,p1,Fx\n0,1,2\n0.1,nan,3\n", "line 3, column 'p1': 'nan' is not a finite number"),
    ("time,p1,Fx\n0,1,2\n0.1,1O,3\n", "line 3, column 'p1': '1O' is not a finite number"),
    ("time,p1,Fx\n0,1,2\n0.2,1,3\n# note\n0.1,1,3\n", "line 5, column 'time': time 0.1 does "
                                                     "not increase"),
    ("time,p1,Fx\n0,1,2\n0.1,1\n", "line 3: 2 cells for 3 columns"),
])
def test_bad_csv_is_one_line_naming_line_and_column(tmp_path, capsys, body, where):
  path = _csv(tmp_path, body)
  code = cli.main(["fit", "--csv", str(path), "--inputs", "p1", "--targets", "Fx",
                   "--method", "ls", "--out", str(tmp_path / "e.npz")])
  err = capsys.readouterr().err.strip().splitlines()
  assert code == 2 and len(err) == 1 and where in err[0] and str(path) in err[0], err


def test_a_missing_column_names_the_columns_the_file_has(tmp_path, capsys):
  path = _csv(tmp_path, "time,p1,Fx\n0,1,2\n0.1,2,3\n")
  code = cli.main(["fit", "--csv", str(path), "--inputs", "p*", "--targets", "Fy",
                   "--method", "ls", "--out", str(tmp_path / "e.npz")])
  err = capsys.readouterr().err
  assert code == 2 and "--targets" in err and "'Fy'" in err and "time, p1, Fx" in err


def test_units_row_and_globs_are_read(tmp_path):
  path = _csv(tmp_path, "# a comment\ntime,p1,p2,Fx\ns,counts,counts,N\n0,1,2,3\n1,4,5,6\n")
  t = csvfile.read(path)
  assert t.units == ("s", "counts", "counts", "N") and t.columns(["p*"], "x") == [1, 2]
  np.testing.assert_array_equal(t.data, [[0, 1, 2, 3], [1, 4, 5, 6]])


def test_names_holding_glob_characters_are_read_as_they_are(tmp_path, capsys):
  """Column names with their units in brackets (`X0 [uT]`, `F_x [N]`): a whole name is that
  column, in fit's options and in the estimator's own names when it predicts and evaluates
  on the same file (a glob would read `[N]` as one character of a set, and match nothing)."""
  counts, forces = _data(300)
  names = [f"X{i} [uT]" for i in range(6)] + ["F_x [N]", "F_y [N]", "F_z [N]"]
  path = csvfile.write(tmp_path / "r.csv", names, np.column_stack([counts, forces]))
  t = csvfile.read(path)
  assert t.columns(["F_x [N]"], "--targets") == [6] and t.columns(["X*"], "x") == list(range(6))
  est = tmp_path / "e.npz"
  assert cli.main(["fit", "--csv", str(path), "--inputs", "X*", "--targets", "F_x [N],F_y [N]",
                   "--method", "ls", "--folds", "0", "--out", str(est)]) == 0
  assert cli.main(["predict", str(est), "--csv", str(path), "--out",
                   str(tmp_path / "p.csv")]) == 0
  assert cli.main(["evaluate", str(est), "--csv", str(path), "--out",
                   str(tmp_path / "ev")]) == 0
  got = csvfile.read(tmp_path / "p.csv")
  assert got.names == ("F_x [N]", "F_y [N]")
  capsys.readouterr()


def test_quoted_numbers_and_blank_lines_are_read(tmp_path):
  path = _csv(tmp_path, 'time,p1,Fx\n\n"0","1.5",2\n# c\n1,2,"-3e2"\n')
  np.testing.assert_array_equal(csvfile.read(path).data, [[0, 1.5, 2], [1, 2, -300]])


def test_csv_write_then_read_gives_the_same_float64_bytes(tmp_path):
  data = np.random.default_rng(1).normal(size=(50, 3)) * 1e3
  csvfile.write(tmp_path / "x.csv", ["a", "b", "c"], data, ["N", "N", "N"])
  assert csvfile.read(tmp_path / "x.csv").data.tobytes() == data.tobytes()


# ---- estimators that know what they were fitted on ---------------------------------------

def test_info_holds_names_units_ranges_and_the_datas_hash(tmp_path):
  counts, forces = _data()
  est = estimators.fit("POLY", counts, forces, inputs=[f"p{i}" for i in range(6)],
                       outputs=["Fx", "Fy", "Fz"])
  est.save(tmp_path / "e.npz")
  back = estimators.Estimator.load(tmp_path / "e.npz")
  assert back.info.inputs[0] == "p0" and back.info.outputs == ("Fx", "Fy", "Fz")
  assert back.info.output_units == ("N",) * 3 and back.info.input_units == ("counts",) * 6
  np.testing.assert_array_equal(back.info.input_lo, counts.min(axis=0))
  assert back.info.data_sha256 == estimators.data_digest(counts, forces)
  assert back.info.settings["method"] == "POLY" and back.info.settings["degree"] == 3
  np.testing.assert_array_equal(back.predict(counts), est.predict(counts))


def test_residual_spread_is_the_held_out_error():
  """On a linear map with known noise, LS's validation residual spread is that noise."""
  rng = np.random.default_rng(2)
  counts = rng.normal(size=(20000, 4)) * 100
  forces = counts @ rng.normal(size=(4, 2)) + rng.normal(size=(20000, 2)) * [0.5, 2.0]
  est = estimators.fit("LS", counts, forces)
  assert est.info.residual_sd == pytest.approx([0.5, 2.0], rel=0.05)


def test_out_of_range_inputs_warn_once_with_their_share():
  counts, forces = _data()
  est = estimators.fit("LS", counts, forces)
  new = counts[:200].copy()
  new[:50, 2] = 5000  # a quarter outside on channel in2
  with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    est.predict(new)
  assert len(caught) == 1 and caught[0].category is estimators.OutOfRangeWarning
  assert "25.0% of the 200 samples" in str(caught[0].message) and "in2" in str(caught[0].message)
  with warnings.catch_warnings():
    warnings.simplefilter("error")
    est.predict(counts[:200])  # inside: silent


def test_an_ensemble_predicts_its_members_mean_and_their_spread(tmp_path):
  counts, forces = _data()
  est = estimators.fit("NN", counts, forces, config=FAST, ensemble=3, seed=4)
  assert len(est.members) == 3
  each = np.stack([m.predict(counts[:100]) for m in est.members])
  mean, sd = est.predict(counts[:100], return_std=True)
  np.testing.assert_allclose(mean, each.mean(axis=0))
  np.testing.assert_allclose(sd, np.sqrt(each.std(axis=0) ** 2 + est.info.residual_sd ** 2))
  est.save(tmp_path / "ens.npz")
  again = estimators.Estimator.load(tmp_path / "ens.npz")
  np.testing.assert_array_equal(again.predict(counts[:100]), mean)


def test_load_refuses_a_format_version_it_does_not_know(tmp_path):
  counts, forces = _data()
  estimators.fit("LS", counts, forces).save(tmp_path / "e.npz")
  with np.load(tmp_path / "e.npz") as z:
    arrays = {k: z[k] for k in z.files}
  meta = json.loads(str(arrays.pop("meta")))
  meta["version"] = 99
  np.savez(tmp_path / "future.npz", meta=json.dumps(meta), **arrays)
  with pytest.raises(errors.DataError, match="format version 99"):
    estimators.Estimator.load(tmp_path / "future.npz")


# ---- the scikit-learn face -----------------------------------------------------------------

def test_the_wrapper_fits_and_scores_as_the_estimator_does():
  counts, forces = _data()
  model = ForceCalibrator(method="ls").fit(counts, forces)
  est = estimators.fit("LS", counts, forces)
  np.testing.assert_array_equal(model.predict(counts), est.predict(counts))
  assert model.score(counts, forces) == pytest.approx(
      np.mean(metrics.r2_pct(est.predict(counts), forces)) / 100)
  assert model.get_params()["method"] == "ls" and model.n_features_in_ == 6
  one = ForceCalibrator(method="poly", degree=2).fit(counts, forces[:, 2])
  assert one.predict(counts).shape == (len(counts),)
  with pytest.raises(ValueError, match="unknown parameter"):
    model.set_params(alpha=1)


# ---- simulator -> CSV -> command = the Python path -----------------------------------------

@pytest.fixture(scope="module")
def footpad_csv(tmp_path_factory, quick_footpad):
  from benchmarks.footpad import dataset
  from sim.footpad import protocol
  out = tmp_path_factory.mktemp("csv")
  recs = quick_footpad
  train = recs["train"].on_path(*protocol.LS_PATHS, "asterisk")
  test = recs["test"].on_path()
  dataset.recording_csv(train, out / "train.csv", step=10)
  dataset.recording_csv(test, out / "test.csv", step=10)
  return out, train.select(np.arange(len(train)) % 10 == 0), test.select(
      np.arange(len(test)) % 10 == 0)


@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
@pytest.mark.parametrize("method, extra", [("ls", []), ("nn", ["--epochs", "5", "--hidden", "5"])])
def test_csv_round_trip_gives_the_python_paths_metrics(footpad_csv, tmp_path, method, extra,
                                                       capsys):
  out, train, test = footpad_csv
  est_path = tmp_path / f"{method}.npz"
  assert cli.main(["fit", "--csv", str(out / "train.csv"), "--inputs", "p*", "--targets",
                   "Fx,Fy,Fz", "--method", method, "--out", str(est_path), "--no-progress",
                   *extra]) == 0
  assert cli.main(["evaluate", str(est_path), "--csv", str(out / "test.csv"), "--out",
                   str(tmp_path / "ev")]) == 0
  got = json.loads((tmp_path / "ev" / "metrics.json").read_text())["results"]
  cfg = mlp.LMConfig(hidden=5, epochs=5)
  with warnings.catch_warnings():
    warnings.simplefilter("ignore", estimators.OutOfRangeWarning)
    # the command's default split: contiguous blocks from the inputs' autocorrelation
    groups = splits.groups(len(train.counts), "auto", None, train.counts)
    est = estimators.fit(method.upper(), train.counts, train.wrench[:, :3], config=cfg,
                         groups=groups, folds=5)
    want = evaluate_cli.scores(est.predict(test.counts), test.wrench[:, :3], ("Fx", "Fy", "Fz"),
                      ("N",) * 3)
  for ax in ("Fx", "Fy", "Fz"):
    for key in ("rmse", "nrmse_pct", "r2_pct", "median_pct", "worst_pct"):
      assert got[ax][key] == pytest.approx(want[ax][key], rel=1e-9, abs=1e-12), (ax, key)
  assert (tmp_path / "ev" / "figures" / "over_time.png").exists()
  assert (tmp_path / "ev" / "figures" / "predicted_vs_true.png").exists()
  assert cli.main(["predict", str(est_path), "--csv", str(out / "test.csv"), "--std", "--out",
                   str(tmp_path / "p.csv")]) == 0
  pred = csvfile.read(tmp_path / "p.csv")
  assert pred.names == ("time", "Fx", "Fy", "Fz", "Fx_sd", "Fy_sd", "Fz_sd")
  np.testing.assert_allclose(pred.data[:, 1:4], est.predict(test.counts), rtol=1e-12,
                             atol=1e-9)
  assert (pred.data[:, 4:] > 0).all()


def test_the_shipped_example_is_what_the_simulator_writes(tmp_path, quick_footpad):
  import pathlib
  import calibrate
  from benchmarks.footpad import dataset
  from models import footpad as model_lib
  if model_lib.arm_dynamics()[0] != "native":  # the example was written with native arms
    pytest.skip(f"the rubber's arms integrate otherwise here: {model_lib.arm_dynamics()[1]}")
  shipped = pathlib.Path(calibrate.__file__).parent / "examples"
  dataset.example_csv(tmp_path, quick_footpad)
  for name in ("train.csv", "test.csv"):
    a, b = csvfile.read(shipped / name), csvfile.read(tmp_path / name)
    assert a.names == b.names and a.units == b.units and a.data.shape == b.data.shape
    np.testing.assert_allclose(a.data, b.data, rtol=1e-9, atol=1e-9)


# ---- the estimator in C --------------------------------------------------------------------

CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
def _auto(counts, forces):
  from calibrate import splits
  from calibrate.parts import deep
  est, _ = estimators.fit_auto(counts, forces, splits.groups(len(counts), "blocks", block=100),
                               3, config=FAST, seed=1, deep=deep.DeepConfig(epochs=10),
                               layers=(16,))
  return est


@pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on this machine")
@pytest.mark.parametrize("kind, ensemble, cross", [("AUTO", 1, False),
    ("LS", 1, False), ("POLY", 1, False), ("POLY", 1, True), ("LSANN", 1, False),
    ("NN", 2, False), ("LSANN", 3, False), ("MLP", 2, False), ("MLP-relu", 1, False)])
@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_the_c_estimator_agrees_with_the_python_one(tmp_path, kind, ensemble, cross):
  from calibrate.parts import deep
  counts, forces = _data()
  kind, _, activation = kind.partition("-")  # MLP-relu: the perceptron of ReLU units
  units = {"deep": deep.DeepConfig(activation=activation)} if activation else {}
  est = _auto(counts, forces) if kind == "AUTO" else estimators.fit(
      kind, counts, forces, config=FAST, ensemble=ensemble, seed=1, cross=cross,
      ridge=1e-6 if cross else None, **units)
  report = cexport.write(est, tmp_path)
  # past the training range too: the cross-term polynomial's tangent plane out there
  test = np.random.default_rng(9).integers(300, 3900, (300, 6))
  c_out = cexport.run_on_host(est, test, cc=CC)
  want = est.predict(test.astype(float))
  # float32 weights and arithmetic: agreement relative to each output's scale
  scale = np.abs(want).max(axis=0)
  assert np.max(np.abs(c_out - want) / scale) < 1e-5
  assert report.multiply_adds > 0 and report.flash_bytes >= 4 * est.n_inputs
  if kind != "AUTO":  # AUTO's parts are whichever won
    # the perceptron's 64 x 64 units: tanhf each where they are tanh, none where ReLU
    assert report.tanh == (0 if kind in ("LS", "POLY") else
                           (0 if activation == "relu" else 128 * ensemble) if kind == "MLP"
                           else 6 * ensemble)
  if kind == "LSANN" and ensemble > 1:  # the shared linear stage once
    assert (tmp_path / "estimator.c").read_text().count("_LIN_COEF[") == 2


def _toward_centre(x, lo, hi):
  """Each row pulled along the line to the box's centre until inside (written out here,
  apart from `calibrate.parts.base`): the smallest share of each input's half-width."""
  centre, half = (lo + hi) / 2, (hi - lo) / 2
  t = np.minimum(1.0, np.min(half / np.maximum(np.abs(x - centre), 1e-300), axis=1))
  return centre + t[:, None] * (x - centre)


def _continued(part, lin, x, est):
  """`part` past the box as `auto` continues it (written out here, apart from
  `calibrate.compose`): its correction to LS where the line to the box's centre leaves the
  box, carried along LS whole up to the folds' reach and faded out past it."""
  lo, hi, reach = est.info.input_lo, est.info.input_hi, est.root.reach
  c = _toward_centre(x, lo, hi)
  d = np.sqrt(np.sum((np.maximum(np.maximum(lo - x, x - hi), 0) / (hi - lo)) ** 2, axis=1))
  keep = np.exp(-np.maximum(d - reach, 0) / max(reach, 0.01))
  return lin.predict(x) + keep[:, None] * (part.predict(c) - lin.predict(c))


def test_the_point_past_the_box_keeps_the_inputs_pattern():
  from calibrate.parts.base import toward_centre
  lo, hi = np.array([0.0, 0.0, 10.0]), np.array([2.0, 4.0, 20.0])
  x = np.array([[1.0, 2.0, 15.0], [3.0, 2.0, 15.0], [5.0, 8.0, 15.0], [-1.0, 6.0, 25.0]])
  got = toward_centre(x, lo, hi)
  np.testing.assert_array_equal(got[0], x[0])  # inside: itself
  np.testing.assert_allclose(got[1:], _toward_centre(x[1:], lo, hi))
  # on the box's surface, on the line from the centre: the same direction, shorter
  d, e = got - (lo + hi) / 2, x - (lo + hi) / 2
  assert np.all(np.isclose(np.max(np.abs(d) / ((hi - lo) / 2), axis=1)[1:], 1.0))
  np.testing.assert_allclose(np.cross(d, e), 0, atol=1e-12)
  # a constant input is held at its value
  flat = toward_centre(x, np.array([0.0, 0.0, 15.0]), np.array([2.0, 4.0, 15.0]))
  assert np.all(flat[:, 2] == 15.0)


@pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on this machine")
def test_auto_continues_its_networks_along_the_ls_plane_beyond_the_box(tmp_path):
  """AUTO keeping a network: inside the training box it is the network; past the box it is
  the network where the line to the box's centre leaves the box plus the LS plane's rise
  from there, in Python and in C, as far as the held-out samples lay past their folds'
  boxes; past that the network's correction to LS fades out: far out, the estimate is LS
  alone. The file keeps that reach."""
  from calibrate import splits
  counts, forces = _data()
  groups = splits.groups(len(counts), "blocks", block=100)
  est, _ = estimators.fit_auto(counts, forces, groups, 3, candidates=("LS", "NN"),
                               config=FAST, seed=1)
  reach = 0.0  # the farthest a held-out sample lay past its training fold's box
  for tr, va in splits.folds(groups, 3, 1):
    lo, hi = counts[tr].min(axis=0), counts[tr].max(axis=0)
    over = np.maximum(np.maximum(lo - counts[va], counts[va] - hi), 0) / (hi - lo)
    reach = max(reach, np.sqrt((over ** 2).sum(axis=1)).max())
  assert est.root.reach == pytest.approx(reach, rel=1e-12) and reach > 0
  whole = estimators.Estimator(est.kind, dataclasses.replace(est.root, reach=None), est.info)
  lo, hi = est.info.input_lo, est.info.input_hi
  near = np.tile((lo + hi) / 2, (3, 1))
  near[:, 0] = hi[0] + np.array([0.2, 0.5, 0.9]) * reach * (hi[0] - lo[0])
  far = np.tile((lo + hi) / 2, (3, 1))
  far[:, 0] = hi[0] + np.array([40.0, 60.0, 80.0]) * max(reach, 0.01) * (hi[0] - lo[0])
  with warnings.catch_warnings():
    warnings.simplefilter("ignore", estimators.OutOfRangeWarning)
    np.testing.assert_array_equal(est.predict(near), whole.predict(near))
    ls_alone = est.parts[est.guard()].predict(far)
    for j, k in enumerate(est.pick):
      if not est.parts[k].kind is estimators.Kind.LS:
        np.testing.assert_allclose(est.predict(far)[:, j], ls_alone[:, j], rtol=1e-9,
                                   atol=1e-9 * np.abs(ls_alone[:, j]).max())
        assert np.all(np.abs(whole.predict(far)[:, j] - ls_alone[:, j]) > 1e-6)
  est.save(tmp_path / "auto.npz")
  assert estimators.Estimator.load(tmp_path / "auto.npz").root.reach == est.root.reach
  with np.load(tmp_path / "auto.npz") as z:  # a reach no fit gives is refused by name
    arrays = dict(z)
  arrays["meta"] = np.array(str(arrays["meta"]).replace(f'"reach": {est.root.reach!r}',
                                                         '"reach": -1.0'))
  assert '"reach": -1.0' in str(arrays["meta"])
  np.savez(tmp_path / "bad.npz", **arrays)
  with pytest.raises(errors.DataError, match=r"reach .* -1.0: allowed a number >= 0"):
    estimators.Estimator.load(tmp_path / "bad.npz")
  nets = [k for k, p in enumerate(est.parts) if p.kind is estimators.Kind.NN]
  ls = est.guard()
  assert nets and ls is not None and est.parts[ls].kind is estimators.Kind.LS
  rng = np.random.default_rng(3)
  inside = rng.integers(600, 3500, (50, 6)).astype(float)
  beyond = rng.integers(0, 4095, (200, 6)).astype(float)
  with __import__("warnings").catch_warnings():
    __import__("warnings").simplefilter("ignore", estimators.OutOfRangeWarning)
    got_in, got = est.predict(inside), est.predict(beyond)
    part, lin = est.parts[nets[0]], est.parts[ls]
    want = _continued(part, lin, beyond, est)
  for j, k in enumerate(est.pick):
    if k == nets[0]:
      np.testing.assert_allclose(got_in[:, j], part.predict(inside)[:, j])
      np.testing.assert_allclose(got[:, j], want[:, j])
  c_out = cexport.run_on_host(est, beyond, cc=CC)
  assert np.max(np.abs(c_out - got) / np.abs(got).max(axis=0)) < 1e-5


@pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on this machine")
@pytest.mark.slow  # over ~3 s of its own on 2 cores: the inner loop leaves it out
def test_auto_keeping_a_mean_of_networks_exports_it(tmp_path):
  """An ensemble `auto` keeps (NNx2) is a mean of networks inside its per-output part: the C
  averages the members as `predict` does, inside the box and beyond it."""
  from calibrate import splits
  counts, forces = _data(600)
  est, table = estimators.fit_auto(counts, forces, splits.groups(600, "blocks", block=100), 3,
                                   candidates=("NNx2",), config=FAST, seed=1)
  assert est.info.validation["chosen"] == ["NNx2"] * 3 and list(table) == ["NNx2"]
  assert len(est.parts[est.pick[0]].members) == 2
  test = np.random.default_rng(9).integers(0, 4095, (300, 6))
  with __import__("warnings").catch_warnings():
    __import__("warnings").simplefilter("ignore", estimators.OutOfRangeWarning)
    want = est.predict(test.astype(float))
  c_out = cexport.run_on_host(est, test, cc=CC)
  assert np.max(np.abs(c_out - want) / np.abs(want).max(axis=0)) < 1e-5


@pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on this machine")
def test_auto_keeps_each_channels_cubic_where_it_is_the_truth_and_guards_it(tmp_path):
  """Targets that are each channel's cube, no cross terms: `auto` keeps POLY-CH (the
  simplest within a standard error of the best); past the box the cube is taken where the
  line to the box's centre leaves it and continued along the LS plane, not grown as a
  cube, in Python and in C."""
  from calibrate import splits
  rng = np.random.default_rng(4)
  counts = rng.uniform(500, 3500, (900, 3))
  z = (counts - 2000) / 1000
  # noise 0.03 N: at 0.01 the ten held-out samples beyond their folds' boxes, continued
  # along the plane, set POLY-CH and POLY (both hold the truth) apart by more than the tie
  forces = np.column_stack([z[:, 0] ** 3 + z[:, 1], 2 * z[:, 1] ** 3 - z[:, 2] ** 2,
                            z[:, 2] ** 3]) + rng.normal(0, 0.03, (900, 3))
  est, table = estimators.fit_auto(counts, forces, splits.groups(900, "blocks", block=90), 3,
                                   candidates=("LS", "POLY-CH", "POLY"), seed=1)
  assert est.info.validation["chosen"] == ["POLY-CH"] * 3, table
  beyond = rng.uniform(0, 4095, (200, 3))
  with __import__("warnings").catch_warnings():
    __import__("warnings").simplefilter("ignore", estimators.OutOfRangeWarning)
    got = est.predict(beyond)
    cubic, lin = est.parts[est.pick[0]], est.parts[est.guard()]
    np.testing.assert_allclose(got, _continued(cubic, lin, beyond, est), rtol=1e-10,
                               atol=1e-12 * np.abs(got).max())
    want = est.predict(beyond.round())
  c_out = cexport.run_on_host(est, beyond.round(), cc=CC)
  assert np.max(np.abs(c_out - want) / np.abs(want).max(axis=0)) < 1e-5


@pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on this machine")
def test_auto_lets_a_part_extrapolate_itself_where_that_held_out_better(tmp_path):
  """Recordings reaching ever further, each channel's cube the truth: held out, the last
  lies past the others' box, where the cube continued as itself is right and along the LS
  plane is not; `auto` keeps POLY-CH unguarded there, and predicts with the cube itself past
  the box. With one output's flag set again, that output follows the plane and the other
  the cube, in Python, in C and through a saved file."""
  rng = np.random.default_rng(1)
  counts = np.vstack([rng.uniform(500, 1500 + 400 * k, (150, 3)) for k in range(6)])
  rec = np.repeat(np.arange(6), 150)
  z = (counts - 2000) / 1000
  forces = np.column_stack([z[:, 0] ** 3 + z[:, 1], 2 * z[:, 2] ** 3 - z[:, 1]]) \
      + rng.normal(0, 0.01, (900, 2))
  est, _ = estimators.fit_auto(counts, forces, splits.groups(900, "recordings", rec), 3,
                               candidates=("LS", "POLY-CH"), seed=1)
  v = est.info.validation
  assert v["chosen"] == ["POLY-CH unguarded"] * 2 and v["held_out_beyond_box"] >= 20, v
  cv = v["candidates"]
  assert all(o < 0.2 * p for o, p in zip(cv["POLY-CH unguarded"], cv["POLY-CH"])), cv
  beyond = np.round(rng.uniform(0, 4095, (200, 3)))
  cubic, lin = est.parts[est.pick[0]], est.parts[est.guard()]
  with warnings.catch_warnings():
    warnings.simplefilter("ignore", estimators.OutOfRangeWarning)
    np.testing.assert_allclose(est.predict(beyond), cubic.predict(beyond), rtol=1e-12)
    mixed = estimators.Estimator(est.kind, dataclasses.replace(est.root, plane=(False, True)),
                                 est.info)
    got = mixed.predict(beyond)
    np.testing.assert_allclose(got[:, 0], cubic.predict(beyond)[:, 0], rtol=1e-12)
    np.testing.assert_allclose(got[:, 1], _continued(cubic, lin, beyond, est)[:, 1],
                               rtol=1e-10, atol=1e-12 * np.abs(got[:, 1]).max())
    mixed.save(tmp_path / "mixed.npz")
    again = estimators.Estimator.load(tmp_path / "mixed.npz")
    assert again.root.plane == (False, True)
    np.testing.assert_array_equal(again.predict(beyond), got)
  c_out = cexport.run_on_host(mixed, beyond, cc=CC)
  assert np.max(np.abs(c_out - got) / np.abs(got).max(axis=0)) < 1e-5


def test_the_export_report_counts_a_known_network():
  """LSANN, 6 inputs, 10 hidden, 3 outputs: LS 6 x 3 = 18, network 10 x 7 + 3 x 11 + 6 + 3
  = 112, the final scaling 3: 133 multiply-adds; weights (6 + 6 + 18 + 3) + (6 + 6 + 70 +
  33 + 3 + 3) floats."""
  counts, forces = _data()
  est = estimators.fit("LSANN", counts, forces, config=mlp.LMConfig(hidden=10, epochs=2))
  r = cexport.write(est, "/tmp/unused-export-dir")
  assert r.multiply_adds == 133 and r.tanh == 10
  assert r.flash_bytes == 4 * (33 + 121)
  text = r.text()
  assert "96 MHz" in text and "96,000" in text


ARM_CC, QEMU = shutil.which("arm-linux-gnueabi-gcc"), shutil.which("qemu-arm")
BENCH = r"""
#include <stdio.h>
#include <stdlib.h>
#include "estimator.h"
int main(int argc, char **argv) {
  int n = atoi(argv[1]);
  uint16_t c[ESTIMATOR_INPUTS] = {2100, 2200, 1900, 2500, 2300, 2000};
  float out[ESTIMATOR_OUTPUTS]; volatile float sink = 0;
  for (int k = 0; k < n; ++k) { c[0] = (uint16_t)(2000 + k % 7); estimate(c, out); sink += out[0]; }
  printf("%g\n", (double)sink);
  return 0;
}
"""


@pytest.mark.skipif(ARM_CC is None or QEMU is None,
                    reason="needs Debian's gcc-arm-linux-gnueabi and qemu-user")
def test_the_budgets_instruction_counts_match_an_arm_run(tmp_path):
  """The cycle model's instruction counts (74 per soft-float multiply-add, 1,700 per tanhf)
  against the instructions qemu-arm executes per estimate, compiled for Thumb-2 soft float."""
  counts, forces = _data()
  est = estimators.fit("LSANN", counts, forces, config=mlp.LMConfig(hidden=10, epochs=2))
  report = cexport.write(est, tmp_path)
  per_estimate = cexport.arm_instructions_per_estimate(tmp_path, BENCH, calls=40)
  model = (report.multiply_adds * cexport.Budget().mac_cycles[0]
           + report.tanh * cexport.Budget().tanh_cycles[0])
  assert per_estimate == pytest.approx(model, rel=0.15)


@pytest.mark.parametrize("args, says", [
    (["--method", "ls", "--ensemble", "3"], "--ensemble is not an option of --method ls"),
    # each method reads the options of the families it is built from (calibrate.parts)
    (["--method", "poly", "--epochs", "5"], "--epochs is not an option of --method poly: it "
                                            "reads --degree, --per-channel"),
    (["--method", "lsann", "--degree", "2"], "--degree is not an option of --method lsann"),
    (["--method", "gru", "--weight-decay", "0.1"], "--weight-decay is not an option of "
                                                   "--method gru"),
    (["--method", "ls", "--seed", "-1"], "seed=-1 is out of range"),
    (["--method", "nn", "--hidden", "0"], "hidden=0 is out of range"),
    (["--method", "poly", "--degree", "0"], "degree=0 is out of range"),
])
def test_fit_settings_out_of_range_are_one_line(tmp_path, capsys, args, says):
  import calibrate
  import pathlib
  train = pathlib.Path(calibrate.__file__).parent / "examples" / "train.csv"
  code = cli.main(["fit", "--csv", str(train), "--inputs", "p*", "--targets", "Fx,Fy,Fz",
                   "--out", str(tmp_path / "e.npz"), *args])
  err = capsys.readouterr().err.strip().splitlines()
  assert code == 2 and len(err) == 1 and says in err[0], err


def test_a_bug_in_the_command_says_so_and_saves_its_traceback(tmp_path, capsys, monkeypatch):
  import calibrate
  import pathlib
  monkeypatch.setenv("TESTBENCH_CACHE", str(tmp_path))
  from calibrate.cli import fit
  monkeypatch.setattr(fit, "run", lambda args: 1 / 0)
  train = pathlib.Path(calibrate.__file__).parent / "examples" / "train.csv"
  code = cli.main(["fit", "--csv", str(train), "--inputs", "p*", "--targets", "Fx",
                   "--method", "ls"])
  err = capsys.readouterr().err
  assert code == 3 and "internal error" in err and "ZeroDivisionError" in err
  assert list((tmp_path / "tracebacks").glob("calibrate-*.txt"))


@pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on this machine")
@pytest.mark.parametrize("kind", ["LS", "POLY", "LSANN", "NN"])
def test_an_estimator_of_signed_fractional_inputs_exports_a_float_signature(tmp_path, kind):
  """Volts after a tare (-2..2) and signed microtesla (+-300): not counts. The export takes
  float inputs, and the compiled estimator matches predict within 1e-5 of each output's
  scale (the uint16_t signature would have wrapped the negative values)."""
  rng = np.random.default_rng(3)
  volts = rng.uniform(-2, 2, (1500, 2))
  tesla = rng.uniform(-300, 300, (1500, 2))
  x = np.column_stack([volts, tesla])
  y = np.column_stack([x @ [1.0, -2.0, 0.01, 0.02], np.tanh(x[:, 0]) * 5 + 0.001 * x[:, 2] ** 2])
  est = estimators.fit(kind, x, y, config=FAST, seed=2, degree=2,
                       input_units=["V", "V", "uT", "uT"])
  cexport.write(est, tmp_path)
  header = (tmp_path / "estimator.h").read_text()
  assert "const float inputs[ESTIMATOR_INPUTS]" in header and "uint16_t counts" not in header
  test = np.column_stack([rng.uniform(-2, 2, (200, 2)), rng.uniform(-300, 300, (200, 2))])
  test = test.astype(np.float32).astype(float)  # what the C reads
  c_out = cexport.run_on_host(est, test, cc=CC)
  want = est.predict(test)
  scale = np.abs(want).max(axis=0)
  assert np.max(np.abs(c_out - want) / scale) < 1e-5
