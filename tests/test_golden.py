"""Estimator files written by earlier versions keep giving the same numbers and the same C.

Every estimator shape `calibrate` writes (LS; POLY per channel and with cross terms; LSANN
with folds; an LSANN ensemble; NN with fewer network inputs; NN on float inputs; AUTO with
its guard beyond the training box; LS and LSANN behind the memory front end with a drift
tare; GRU, exported in float and in Q16; a command-line fit with `--tare`) was fitted once on
small deterministic data and saved in format version 3 under `tests/golden/`, with what it
gave then: `predict`'s mean and spread on a probe reaching 30 % beyond the training box, the
exported C text and its cost counts. The tests read those files with today's code (the v3
reader), save them again and read them back (today's format), and compare: predictions to
rtol 1e-12, the C text exactly.

Refit every shape with the code checked out and compare with the files (a refit's numbers
hold on the machine that wrote them, with its numpy, JAX and BLAS builds), or regenerate them
(only for a change meant to alter them, said in its commit):

    python tests/test_golden.py check
    python tests/test_golden.py write
"""

from __future__ import annotations

import json
import pathlib
import sys
import warnings

import numpy as np
import pytest

HERE = pathlib.Path(__file__).parent / "golden"
DT = 0.01


def _static(n=400, seed=0, integer=True):
  """(counts (n, 4), forces (n, 3), recording labels (n,)): smooth nonlinear maps."""
  rng = np.random.default_rng(seed)
  counts = rng.uniform(800, 3200, (n, 4))
  if integer:
    counts = np.round(counts)
  else:
    counts = (counts - 2000) / 400  # volts, signed
  z = (counts - counts.mean(axis=0)) / counts.std(axis=0)
  forces = np.column_stack([z[:, 0] - z[:, 1] + 0.3 * z[:, 0] ** 2,
                            np.tanh(z[:, 2]) * 5 - z[:, 3],
                            40 + 10 * z.sum(axis=1) + z[:, 0] * z[:, 2]])
  return counts, forces + 0.01 * rng.normal(size=forces.shape), np.arange(n) * 4 // n


def _recordings(n=800, segments=4, seed=0):
  """(counts (n, 4), forces (n, 3), segments (n,)): presses from rest, a drifting offset."""
  rng = np.random.default_rng(seed)
  t = np.arange(n) * DT
  fz = np.clip(np.sin(2 * np.pi * t / 1.5), 0, None) * 60
  fx = fz * np.sin(t) * 0.3
  fy = fz * np.cos(0.7 * t) * 0.2
  forces = np.column_stack([fx, fy, fz])
  mix = rng.normal(size=(4, 3)) * 8
  drift = np.outer(t, rng.normal(size=4)) * 3
  counts = np.round(2000 + forces @ mix.T + drift + rng.normal(size=(n, 4)))
  return counts, forces, np.repeat(np.arange(segments), n // segments)


def _probe(counts, n=120, seed=5):
  """Inputs reaching 30 % of the training range beyond it on every side."""
  lo, hi = counts.min(axis=0), counts.max(axis=0)
  span = hi - lo
  return np.random.default_rng(seed).uniform(lo - 0.3 * span, hi + 0.3 * span,
                                             (n, counts.shape[1]))


def _shapes(tmp: pathlib.Path) -> dict:
  """{name: (estimator, probe, predict keywords, export keywords)} fitted with today's code."""
  from calibrate import __main__ as cli
  from calibrate import estimators as E
  from calibrate import splits
  from calibrate.parts import mlp
  from calibrate.parts import gru
  from calibrate.parts import memory
  fast = mlp.LMConfig(hidden=4, epochs=15)
  x, y, rec = _static()
  groups = splits.groups(len(x), "recordings", rec)
  xf, yf, _ = _static(integer=False)
  c, f, seg = _recordings()
  out = {}

  def put(name, est, probe, **kw):
    out[name] = (est, probe, kw)

  p = _probe(x)
  put("ls", E.fit("LS", x, y, groups=groups, folds=2), p)
  put("poly_channel", E.fit("POLY", x, y, degree=3), p)
  put("poly_cross", E.fit("POLY", x, y, cross=True, degree=2, groups=groups, folds=2), p)
  put("lsann_folds", E.fit("LSANN", x, y, config=fast, seed=1, groups=groups, folds=2), p)
  put("lsann_ensemble", E.fit("LSANN", x, y, config=fast, seed=2, ensemble=3), p)
  put("nn_float", E.fit("NN", xf, yf, config=fast, seed=4), _probe(xf))
  with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    # without POLY, whose cubic wins every output here: a network part, and so the guard
    auto, _ = E.fit_auto(x, y, groups, folds=2, config=mlp.LMConfig(hidden=6, epochs=40),
                         seed=5, candidates=("LS", "LSANN", "NN"))
  assert auto.guard() is not None
  put("auto", auto, p)
  tare = memory.Tare(threshold=5.0, hold=5)
  stream = dict(segments=seg)
  pc = np.round(c.mean(axis=0) + 1.6 * (c - c.mean(axis=0)))  # a recording, stretched 30 % past
  put("ls_memory", E.fit_temporal("LS", c, f, DT, segments=seg, taus=(0.3,), tare=tare),
      pc, **stream)
  put("lsann_memory", E.fit_temporal("LSANN", c, f, DT, segments=seg, taus=(0.3,), tare=tare,
                                     config=fast, seed=6), pc, **stream)
  # NN behind the front end: its network reads the tared counts, the first 4 of 8 features
  put("nn_net_inputs", E.fit_temporal("NN", c, f, DT, segments=seg, taus=(0.3,),
                                      differences=False, config=fast, seed=3), pc, **stream)
  put("gru", E.fit_temporal("GRU", c, f, DT, segments=seg, taus=(), differences=False,
                            gru=gru.GRUConfig(hidden=4, steps=30, window=40, burn_in=10), seed=7),
      pc, **stream)
  rows = ["time,p0,p1,p2,p3,Fx,Fy,Fz", "s,counts,counts,counts,counts,N,N,N"]
  cc, fc, _ = _recordings(seed=3)
  fc = fc.copy()
  fc[:40] = 0.0  # the tare window is unloaded
  for k, (cr, fr) in enumerate(zip(cc, fc)):
    rows.append(",".join([f"{k * DT:.2f}"] + [f"{v:.0f}" for v in cr] + [f"{v:.6f}" for v in fr]))
  csv = tmp / "tare.csv"
  csv.write_text("\n".join(rows) + "\n")
  est_path = tmp / "cli_tare.npz"
  code = cli.main(["fit", "--csv", str(csv), "--inputs", "p*", "--targets", "Fx,Fy,Fz",
                   "--method", "ls", "--tare", "0.3", "--folds", "0", "--no-progress",
                   "--out", str(est_path)])
  assert code == 0
  put("cli_tare", E.Estimator.load(est_path), np.round(_probe(cc)))
  return out


EXPORTS = {"gru": [("float", False), ("q16", True)]}


def _record(name, est, probe, kw, tmp: pathlib.Path) -> dict:
  """What an estimator gives: predict's mean and spread, its C and the export's counts."""
  from calibrate import cexport
  with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    mean, sd = est.predict(probe, return_std=True, **kw)
  info_arrays = est.info.arrays() if est.info is not None else {}
  got = {"mean": mean, "sd": sd, "c": {}, "info": info_arrays,
         "info_json": json.dumps(est.info.to_json() if est.info is not None else None)}
  for tag, fixed in EXPORTS.get(name, [("float", False)]):
    report = cexport.write(est, tmp / tag, fixed_point=fixed)
    got["c"][tag] = {"h": (tmp / tag / "estimator.h").read_text(),
                     "c": (tmp / tag / "estimator.c").read_text(),
                     "costs": [report.multiply_adds, report.tanh, report.flash_bytes,
                               report.stack_bytes, report.fixed_multiply_adds,
                               report.fixed_tanh]}
  return got


def write(root: pathlib.Path = HERE) -> None:
  """Fits every shape with the code checked out and writes its v3 file and what it gives."""
  import tempfile
  root.mkdir(exist_ok=True)
  with tempfile.TemporaryDirectory() as d:
    d = pathlib.Path(d)
    for name, (est, probe, kw) in _shapes(d).items():
      est.save(root / f"{name}.npz")
      got = _record(name, est, probe, kw, d / name)
      np.savez_compressed(root / f"{name}.expected.npz", probe=probe, mean=got["mean"], sd=got["sd"],
               stream=json.dumps({k: np.asarray(v).tolist() for k, v in kw.items()}),
               info_json=got["info_json"], **got["info"])
      for tag, text in got["c"].items():
        (root / f"{name}.{tag}.json").write_text(json.dumps(text, indent=0) + "\n")


NAMES = sorted(p.name[:-len(".expected.npz")] for p in HERE.glob("*.expected.npz"))


def _expected(name):
  saved = np.load(HERE / f"{name}.expected.npz")
  return saved


def _check(est, name, tmp):
  saved = _expected(name)
  kw = {k: np.asarray(v) for k, v in json.loads(str(saved["stream"])).items()}
  probe, mean, sd = saved["probe"], saved["mean"], saved["sd"]
  got = _record(name, est, probe, kw, tmp)
  assert got["info_json"] == str(saved["info_json"]), f"{name}: Info's settings"
  held = sorted(k for k in saved.files if k.startswith("info_") and k != "info_json")
  assert sorted(got["info"]) == held, f"{name}: Info's arrays"
  for k in held:
    np.testing.assert_allclose(got["info"][k], saved[k], rtol=1e-12, err_msg=f"{name}: {k}")
  np.testing.assert_allclose(got["mean"], mean, rtol=1e-12, atol=0, err_msg=f"{name}: mean")
  np.testing.assert_allclose(got["sd"], sd, rtol=1e-12, atol=0, err_msg=f"{name}: spread")
  for tag, text in got["c"].items():
    want = json.loads((HERE / f"{name}.{tag}.json").read_text())
    assert text["costs"] == want["costs"], f"{name} ({tag}): cost counts"
    assert text["h"] == want["h"], f"{name} ({tag}): estimator.h differs"
    assert text["c"] == want["c"], f"{name} ({tag}): estimator.c differs"


def test_every_shape_is_kept():
  assert len(NAMES) == 12, NAMES


@pytest.mark.parametrize("name", NAMES)
def test_a_version_3_file_gives_what_it_gave(name, tmp_path):
  from calibrate import estimators
  est = estimators.Estimator.load(HERE / f"{name}.npz")
  _check(est, name, tmp_path)


@pytest.mark.parametrize("name", NAMES)
def test_saved_again_and_read_back_it_gives_the_same(name, tmp_path):
  from calibrate import estimators
  estimators.Estimator.load(HERE / f"{name}.npz").save(tmp_path / "again.npz")
  _check(estimators.Estimator.load(tmp_path / "again.npz"), name, tmp_path)


def check() -> int:
  """Refits every shape and compares with the files: one line per shape; 1 if any differs."""
  import tempfile
  failed = 0
  with tempfile.TemporaryDirectory() as d:
    d = pathlib.Path(d)
    for name, (est, _, _) in _shapes(d).items():
      try:
        _check(est, name, d / name)
        print(f"{name}: same predictions, intervals, C text and cost counts")
      except AssertionError as err:
        failed = 1
        print(f"{name}: DIFFERS: {str(err).strip().splitlines()[0]}")
  return failed


if __name__ == "__main__":
  if sys.argv[1:] == ["write"]:
    write()
  elif sys.argv[1:] == ["check"]:
    sys.exit(check())
  else:
    sys.exit("usage: python tests/test_golden.py check|write")
