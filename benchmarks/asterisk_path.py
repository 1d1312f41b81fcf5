"""asterisk_path: the main job. Generates the footpad data and fits the linear least-squares
calibrator of the LSANN paper (Sec. III-B) on the Z/X/Y strokes, tested on Testing Paths 1-2.

The LSANN and NN-only calibrators of the paper's Table I are not here yet (issue 3)."""

from __future__ import annotations


from benchmarks import footpad_data
from calibrate import linear, metrics
from sim import footpad

DESCRIPTION = "footpad: linear LS calibration on strokes, tested on Testing Paths 1-2"
PAPER_LS_TRAIN_NRMSE = {"Z": 0.42, "X": 9.63, "Y": 5.72}  # paper Sec. III-B
AXES = ("X", "Y", "Z")


def run(ctx) -> dict:
  recs = {}
  for name, scene in footpad_data.scenes(ctx.quick, ctx.seed, ctx.overrides).items():
    recs[name], _ = footpad.generate(scene, ctx.progress(f"{name} episodes"), ctx.use_cache)
  strokes = recs["train"].paths("z_press", "x_stroke", "y_stroke")
  strokes = strokes.select(strokes.phase == 1)
  test = recs["test"].select(recs["test"].phase == 1)
  fit = linear.fit_linear(strokes.counts, strokes.wrench[:, :3])
  res = {"LS": {}, "LS_train": {}}
  for label, rec, key in (("train strokes", strokes, "LS_train"), ("test paths", test, "LS")):
    pred = fit.predict(rec.counts)
    truth = rec.wrench[:, :3]
    for i, ax in enumerate(AXES):
      res[key][ax] = {"rmse": float(metrics.rmse(pred, truth)[i]),
                      "nrmse_pct": float(metrics.nrmse_pct(pred, truth)[i]),
                      "r2_pct": float(metrics.r2_pct(pred, truth)[i])}
  ctx.print(f"linear LS (rank {fit.rank}), {len(strokes)} training / {len(test)} test samples")
  ctx.print(f"{'axis':4s} {'train NRMSE %':>14s} {'paper':>6s} {'test RMSE N':>12s} "
            f"{'test NRMSE %':>13s} {'test R2 %':>10s}")
  for ax in ("Z", "Y", "X"):
    tr, te = res["LS_train"][ax], res["LS"][ax]
    ctx.print(f"{ax:4s} {tr['nrmse_pct']:14.2f} {PAPER_LS_TRAIN_NRMSE[ax]:6.2f} {te['rmse']:12.2f} "
              f"{te['nrmse_pct']:13.2f} {te['r2_pct']:10.2f}")
  ctx.print("LSANN and NN-only (paper Table I) arrive with the calibrators issue.")
  return {"results": res, "paper": {"LS_train_nrmse_pct": PAPER_LS_TRAIN_NRMSE},
          "samples": {"train": len(strokes), "test": len(test)},
          "effects": list(recs["train"].meta["effects"])}
