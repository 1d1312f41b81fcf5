"""What a finished run leaves in its folder: the manifest reruns it, metrics.csv holds every
number of metrics.json, table.md what was printed, and --compare reads an earlier run."""

import json

import pytest

from benchmarks import outputs, run
from util import files


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
  out = tmp_path_factory.mktemp("run") / "geometry"
  assert run.main(["shell_geometry", "--quick", "--seed", "3", "--out", str(out),
                   "--set", "slope_x=0.4"]) == 0
  return out


def test_the_folder_holds_manifest_metrics_csv_and_table(finished, capsys):
  names = {p.name for p in finished.iterdir()}
  assert {"manifest.json", "metrics.json", "metrics.csv", "table.md"} <= names
  manifest = json.loads((finished / "manifest.json").read_text())
  assert manifest["benchmark"] == "shell_geometry" and manifest["seed"] == 3
  assert manifest["settings"]["slope_x"] == "0.4"  # resolved, the override applied
  assert manifest["command"].endswith("--set slope_x=0.4")
  assert {"python", "mujoco", "numpy", "jax"} <= set(manifest["versions"])
  assert {"metrics.json", "metrics.csv", "table.md"} <= set(manifest["files"])


def test_metrics_csv_holds_every_number_of_metrics_json(finished):
  metrics = files.from_json((finished / "metrics.json").read_text())
  rows = outputs.read_rows(finished / "metrics.csv")
  assert len(rows) == len(outputs.plain(metrics))  # shell_geometry: no method, no axis
  by_metric = {(r.group, r.metric): r.value for r in rows}
  assert by_metric[("", "wall_seconds")] == metrics["wall_seconds"]


def test_table_md_is_what_the_run_printed(tmp_path, capsys):
  out = tmp_path / "g"
  run.main(["shell_geometry", "--quick", "--out", str(out)])
  printed = capsys.readouterr().out
  table = (out / "table.md").read_text()
  body = table.split("```\n")[1]
  for line in body.splitlines():
    assert line in printed


def test_rows_take_method_and_axis_from_the_result_never_from_key_spelling():
  data = {"results": {"LSANN": {"X": {"r2_pct": 90.0}}}, "per_seed": [{"NN": {"Z": {
      "rmse": 1.5}}}], "flag": True, "name": "x"}
  assert outputs.plain(data) == [
      outputs.Row("results/LSANN/X", "", "", "r2_pct", 90.0),
      outputs.Row("per_seed/0/NN/Z", "", "", "rmse", 1.5)]
  scored = outputs.scored("results", data["results"], {"LSANN": {"X": {"r2_pct": 0.5}}})
  assert scored == [outputs.Row("results", "LSANN", "X", "r2_pct", 90.0, 0.5)]
  assert outputs.plain(data, skip=(("results",), ("per_seed", "*", "NN"))) == []


def test_compare_prints_the_shared_metrics_side_by_side(finished, tmp_path, capsys):
  out = tmp_path / "again"
  assert run.main(["shell_geometry", "--quick", "--seed", "3", "--out", str(out),
                   "--compare", str(finished)]) == 0
  printed = capsys.readouterr().out
  assert f"compared with {finished}" in printed
  assert "earlier" in printed and "this run" in printed


def test_compare_with_a_folder_that_is_no_run_is_one_line(tmp_path, capsys):
  assert run.main(["shell_geometry", "--quick", "--out", str(tmp_path / "o"),
                   "--compare", str(tmp_path / "nothing")]) == 2
  err = capsys.readouterr().err.strip().splitlines()
  assert len(err) == 1 and "--compare" in err[0] and "metrics.csv" in err[0]


def test_a_quick_run_has_a_folder_apart_from_the_full_run(tmp_path, monkeypatch):
  monkeypatch.chdir(tmp_path)
  assert run.main(["shell_geometry", "--quick"]) == 0
  assert (tmp_path / "results" / "shell_geometry-quick" / "metrics.json").exists()
  assert not (tmp_path / "results" / "shell_geometry").exists()


def test_progress_piped_is_one_line_per_stage(tmp_path, capsys):
  from benchmarks.registry import Context
  ctx = Context(quick=True, seed=0, out=tmp_path, settings=None)
  bar = ctx.progress("LSANN seed 1/5")
  for done in (1, 2, 3):
    bar(done, 1000)
  bar(3, 3)  # training stopped early: the stage ends
  err = capsys.readouterr().err.strip().splitlines()
  assert len(err) == 1 and err[0].startswith("LSANN seed 1/5: 3 done in")
  silent = Context(quick=True, seed=0, out=tmp_path, settings=None,
                   show_progress=False).progress("x")
  silent(1, 3)  # --no-progress: draws nothing
  assert capsys.readouterr().err == ""


def test_training_closes_its_progress_when_it_stops_early():
  import numpy as np
  from calibrate.parts import mlp
  rng = np.random.default_rng(0)
  x = rng.normal(size=(400, 3))
  y = x @ rng.normal(size=(3, 2))
  calls = []
  res = mlp.train(x[:300], y[:300], x[300:], y[300:] + 5.0,  # validation that cannot improve
                  mlp.LMConfig(hidden=3, epochs=200, max_fail=2), progress=lambda d, t:
                  calls.append((d, t)))
  assert res.epochs < 200 and calls[-1] == (res.epochs, res.epochs)
  assert [d for d, _ in calls[:-1]] == list(range(1, res.epochs + 1))


def test_compare_puts_the_headline_results_first():
  old = [outputs.Row(g, "LS", "X", "rmse", 1.0) for g in ("timing", "results", "per_seed/0")]
  new = [outputs.Row(r.group, r.method, r.axis, r.metric, 2.0) for r in old]
  lines = outputs.compare_lines(old, new)
  assert lines[1].startswith("results LS X rmse") and lines[2].startswith("timing")
  assert len(lines) == 3  # the per-seed row left out


def test_compare_marks_a_change_within_the_seeds_spread():
  old = [outputs.Row("results", "NN", "X", "r2_pct", 90.0, 2.0),
         outputs.Row("results", "NN", "Y", "r2_pct", 90.0, 2.0)]
  new = [outputs.Row("results", "NN", "X", "r2_pct", 91.0, 1.5),  # within: ~
         outputs.Row("results", "NN", "Y", "r2_pct", 95.0, 1.5)]  # beyond: a change
  lines = outputs.compare_lines(old, new)
  assert lines[1].endswith(" ~") and not lines[2].endswith("~") and "~:" in lines[-1]
