"""The footpad's identification (`identify_footpad`) and its presets (`--preset`)."""

import json
import math
import sqlite3

import pytest

from benchmarks import identification, run
from benchmarks.footpad import identify
from sim.footpad import paper, presets
from sim.shell import presets as presets_shell


def _result_at(targets, shift: float = 0.0, points: float = 0.0) -> dict:
  """An evaluation whose every cell equals its target, NRMSE-like cells times
  (1 + shift) and R2 cells plus `points`."""
  out = {"results": {}, "LS_train": {}, "ratio": {}}
  for t in targets:
    if t.group == "ratio":
      out["ratio"][t.metric] = t.value * (1 + shift)
      continue
    kind, _ = identification.BANDS[t.metric]
    value = t.value + points if kind == "points" else t.value * (1 + shift)
    out[t.group].setdefault(t.method, {}).setdefault(t.axis, {})[t.metric] = value
  return out


def test_the_papers_own_table_scores_zero_and_one_band_scores_one():
  targets = identify.paper_targets()
  assert identification.score(_result_at(targets), targets) == 0.0
  nrmse = [t for t in targets if t.metric == "nrmse_pct"]
  assert identification.score(_result_at(nrmse, shift=0.25), nrmse) == pytest.approx(1.0)
  r2 = [t for t in targets if t.metric == "r2_pct"]
  assert identification.score(_result_at(r2, points=-8.0), r2) == pytest.approx(1.0)
  # a failed network is far, not everything: its deviation is capped
  far = _result_at(r2, points=-1e4)
  assert identification.score(far, r2) == pytest.approx(identification.CAP ** 2)


def test_the_paper_targets_hold_every_network_cell_and_the_stroke_fit():
  names = {t.name for t in identify.paper_targets()}
  for m in ("LSANN", "NN"):
    for ax in "XYZ":
      assert {f"results/{m}/{ax}/nrmse_pct", f"results/{m}/{ax}/r2_pct"} <= names
  assert {"LS_train/LS/X/nrmse_pct", "LS_train/LS/Y/range", "ratio/epochs_lsann_over_nn"} <= names
  # the test paths' ranges follow from Table I itself: 126 N of shear, 221 N of Z
  test_range = {ax: rmse / nrmse * 100 for ax, (rmse, nrmse, _) in paper.TABLE1["LSANN"].items()}
  assert test_range["Y"] == pytest.approx(126.6, abs=0.1)
  assert test_range["Z"] == pytest.approx(paper.LS_TRAIN_RANGE["Z"], rel=0.01)


def test_targets_from_a_users_metrics_csv(tmp_path):
  table = tmp_path / "mine.csv"
  table.write_text("group,method,axis,metric,value,spread\n"
                   "results,LS,X,nrmse_pct,4.0,\n"
                   "LS_train,LS,Y,range,200,\n"
                   "results/train,LS,,seconds,0.1,\n")  # not a cell identification scores
  got = identification.read_targets(table, identify.scorable, identify.ALLOWED)
  assert [t.name for t in got] == ["results/LS/X/nrmse_pct", "LS_train/LS/Y/range"]
  assert not identify.needs_networks(got)
  (tmp_path / "none.csv").write_text("group,method,axis,metric,value,spread\n"
                                     "results/train,LS,,seconds,0.1,\n")
  with pytest.raises(Exception, match="no row it can score"):
    identification.read_targets(tmp_path / "none.csv", identify.scorable, identify.ALLOWED)


def test_every_preset_value_lies_inside_its_sourced_range():
  for name, preset in presets.presets().items():
    for p in presets.parameters():
      v = preset.design.get(p.key, p.nominal)
      assert p.lo <= v <= p.hi, (name, p.key, v)
    assert "OUTSIDE" not in "\n".join(preset.lines()), name


def test_the_nominal_preset_is_the_protocols_own_settings(capsys):
  # footpad_dataset runs the protocol's own settings when no preset is given
  assert run.main(["footpad_dataset", "--quick", "--check"]) == 0
  without = capsys.readouterr().out
  assert run.main(["footpad_dataset", "--quick", "--check", "--preset", "nominal"]) == 0
  assert capsys.readouterr().out == without


def test_a_preset_applies_under_the_users_set(capsys):
  assert run.main(["asterisk_path", "--quick", "--check", "--preset", "paper",
                   "--set", "adc.hysteresis=0.001"]) == 0
  resolved = dict(line.split(" = ", 1) for line in capsys.readouterr().out.splitlines()
                  if " = " in line)
  assert resolved["adc.hysteresis"] == "0.001"
  paper_stroke = presets.get("paper").design["stroke"]
  assert float(resolved["stroke"]) == pytest.approx(paper_stroke)


def test_an_unknown_preset_is_named(capsys):
  assert run.main(["asterisk_path", "--quick", "--check", "--preset", "papr"]) == 2
  assert "did you mean paper?" in capsys.readouterr().err
  assert run.main(["shell_geometry", "--check", "--preset", "paper"]) == 2
  assert "takes no preset" in capsys.readouterr().err


LS_ONLY = ("group,method,axis,metric,value,spread\n"
           "LS_train,LS,X,nrmse_pct,5.0,\nLS_train,LS,Y,range,200,\nresults,LS,Z,r2_pct,99,\n")


@pytest.mark.slow  # eight trials of one Z level, friction and noise alone, no networks: ~10 s
def test_an_interrupted_study_resumes_to_the_same_designs(tmp_path, capsys):
  (tmp_path / "t.csv").write_text(LS_ONLY)
  # one press and a four-times faster feed: the same study on a fifth of the steps
  common = ["identify_footpad", "--quick", "--no-progress", "--set", f"targets={tmp_path}/t.csv",
            "--set", "scene.z_levels=0.001", "--set", "startup=1",
            "--set", "scene.press_repeats=1", "--set", "scene.feed=0.02",
            "--set", "scene.effects=friction,pressure_friction,stick_slip,sensor_noise"]
  assert run.main(common + ["--out", str(tmp_path / "straight"), "--set", "trials=4"]) == 0
  assert run.main(common + ["--out", str(tmp_path / "resumed"), "--set", "trials=2"]) == 0
  assert run.main(common + ["--out", str(tmp_path / "resumed"), "--set", "trials=4"]) == 0
  capsys.readouterr()

  def designs(folder):
    with sqlite3.connect(folder / "study.db") as db:
      return db.execute("select trial_id, param_name, param_value from trial_params "
                        "order by trial_id, param_name").fetchall()
  assert designs(tmp_path / "straight") == designs(tmp_path / "resumed")
  found = json.loads((tmp_path / "straight" / "preset.json").read_text())
  assert math.isfinite(found["score"]) and found["trials"] == 4
  # a study of other targets is not mixed into the stored one
  (tmp_path / "u.csv").write_text(LS_ONLY.replace("5.0", "6.0"))
  other = [a if a != f"targets={tmp_path}/t.csv" else f"targets={tmp_path}/u.csv" for a in common]
  assert run.main(other + ["--out", str(tmp_path / "straight"), "--set", "trials=4"]) == 2
  assert "holds a study of other settings" in capsys.readouterr().err


def test_cma_es_moves_the_shell_within_its_ranges(tmp_path, capsys):
  """The other sampler: CMA-ES (Optuna's, via `cmaes`) from the best trial so far."""
  out = tmp_path / "cma"
  assert run.main(["identify_shell", "--quick", "--no-progress", "--out", str(out), "--set",
                   "sampler=cmaes", "--set", "trials=4", "--set", "startup=2"]) == 0
  capsys.readouterr()
  found = json.loads((out / "preset.json").read_text())
  assert found["trials"] == 4 and math.isfinite(found["score"])
  for p in presets_shell.parameters():
    assert p.lo <= found["design"][p.key] <= p.hi, p.key
