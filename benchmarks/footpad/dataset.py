"""footpad_dataset: generate and cache the paper's training and test recordings."""

from __future__ import annotations

import dataclasses

import numpy as np

from benchmarks import footpad, outputs
from benchmarks.registry import register


@register("footpad_dataset", "generate and cache the footpad's training and test recordings "
          "(paper Sec. III)", settings=footpad.protocol_settings, presets=footpad.presets,
          fixed=footpad.FIXED,
          tags=("footpad", "data"))
def run(ctx) -> dict:
  from sim import cache
  from sim.footpad import protocol, scene as scene_lib
  out = {"recordings": {}, "timing": {}}
  scenes = protocol.scenes(ctx.settings)
  recordings = footpad.recordings(ctx)
  for name, (rec, timing) in recordings.items():
    ranges = {ax: [float(rec.wrench[:, i].min()), float(rec.wrench[:, i].max())]
              for i, ax in enumerate("XYZ")}
    per_path = {p: int(np.sum(rec.path == i)) for i, p in enumerate(rec.meta["paths"])}
    key = cache.content_key(scene_lib.cache_key(scenes[name]))
    out["recordings"][name] = {"samples": len(rec), "per_path": per_path,
                               "force_range_N": ranges, "cache_key": key}
    stem = cache.cache_dir() / "recordings" / f"footpad-{key}"
    out["recordings"][name]["stem"] = str(stem)
    ctx.print(f"{name}: {len(rec)} samples; " + ", ".join(
        f"F{ax} {lo:+.1f}..{hi:+.1f} N (range {hi - lo:.1f})" for ax, (lo, hi) in ranges.items()))
    ctx.print(f"  Recording.load({str(stem)!r})")
    for p, n in per_path.items():
      ctx.print(f"  {p:12s} {n:8d} samples")
    if timing is None:
      ctx.print("  loaded from cache")
      out["timing"][name] = {"cached": True}
    else:
      out["timing"][name] = {"cached": False, **dataclasses.asdict(timing),
                             "steps_per_s": timing.steps / timing.simulate,
                             "sensor_chain_share": timing.sensor_chain_cpu / timing.physics_cpu}
      ctx.print(f"  {timing.steps} steps in {timing.simulate:.1f} s on {timing.threads} threads "
                f"({timing.steps / timing.simulate:,.0f} steps/s); sensor chain "
                f"{timing.sensor_chain_cpu:.2f} s = "
                f"{timing.sensor_chain_cpu / timing.physics_cpu:.1%} of the physics' "
                f"{timing.physics_cpu:.1f} thread-s; model + kernel {timing.build:.1f} s")
    if rec.slip is not None:
      out["recordings"][name]["slip"] = _slip_table(ctx, rec)
  written = example_csv(ctx.out / "csv", {k: r for k, (r, _) in recordings.items()})
  ctx.print(f"as CSV for python -m calibrate (every {EXAMPLE_STEP}th sample): "
            + ", ".join(str(p) for p in written))
  out["samples"] = sum(r["samples"] for r in out["recordings"].values())
  out["effects"] = list(scenes["train"].effects)
  rows = [r for name, got in out["recordings"].items() for r in outputs.per_axis(
      f"recordings/{name}", {ax: {"force_min_N": lo, "force_max_N": hi}
                             for ax, (lo, hi) in got["force_range_N"].items()})]
  return outputs.Result(out, tuple(rows + outputs.plain(
      out, skip=(("recordings", "*", "force_range_N"),))))


IN_CONTACT = 1.0  # N of normal force: below it a shear/normal ratio means nothing


def _slip_table(ctx, rec) -> list[dict]:
  """Per Z level, on the lateral paths at their indentation: the largest shear/normal ratio
  of the plate's force, the share of samples where any element slides, and the mean share
  of the loaded elements sliding (`Recording.slip`)."""
  lateral = [i for i, p in enumerate(rec.meta["paths"]) if p != "z_press"]
  on = (rec.phase == 1) & np.isin(rec.path, lateral)
  rows = []
  ctx.print(f"  slip by Z level (lateral paths): {'z mm':>6s} {'max Ft/Fz':>10s} "
            f"{'any slides':>11s} {'elements sliding':>17s}")
  for z in np.unique(rec.z_level[on]):
    m = on & (rec.z_level == z) & (rec.wrench[:, 2] > IN_CONTACT)
    if not m.any():
      continue  # the pad only touches the plate: no ratio to speak of
    ratio = float(np.max(np.hypot(rec.wrench[m, 0], rec.wrench[m, 1]) / rec.wrench[m, 2]))
    rows.append({"z_mm": float(z * 1e3), "max_shear_over_normal": ratio,
                 "samples_with_slip": float(np.mean(rec.slip[m] > 0)),
                 "mean_sliding_share": float(np.mean(rec.slip[m]))})
    r = rows[-1]
    ctx.print(f"  {'':31s} {r['z_mm']:6.2f} {ratio:10.2f} {r['samples_with_slip']:11.1%} "
              f"{r['mean_sliding_share']:17.1%}")
  return rows


EXAMPLE_STEP = 20  # every 20th sample of 1 kHz: a 50 Hz example small enough to ship


def recording_csv(rec, path, step: int = 1):
  """Writes a footpad recording as a CSV in `calibrate.csvfile`'s layout: time (s, from the
  first sample, increasing across episodes), the six dies' counts p1..p6 and the plate's force
  Fx, Fy, Fz (N); every `step`-th sample."""
  from calibrate import csvfile
  keep = np.arange(0, len(rec), step)
  t = footpad.clock(rec)[keep]
  d = rec.counts.shape[1]
  names = ["time"] + [f"p{i + 1}" for i in range(d)] + ["Fx", "Fy", "Fz"]
  units = ["s"] + ["counts"] * d + ["N"] * 3
  data = np.column_stack([t, rec.counts[keep], rec.wrench[keep, :3]])
  return csvfile.write(path, names, data, units)


def example_csv(out, recs: dict) -> list:
  """train.csv (the Z presses, X/Y strokes and Asterisk path of the protocol's training
  recording, on the paths at their depth) and test.csv (Testing Paths 1 and 2), every
  `EXAMPLE_STEP`-th sample, from the recordings {"train", "test"}: with the quick protocol at
  seed 0 these are the examples `python -m calibrate example` copies."""
  import pathlib
  from sim.footpad import protocol
  out = pathlib.Path(out)
  out.mkdir(parents=True, exist_ok=True)
  train = recs["train"].on_path(*protocol.LS_PATHS, "asterisk")
  return [recording_csv(train, out / "train.csv", EXAMPLE_STEP),
          recording_csv(recs["test"].on_path(), out / "test.csv", EXAMPLE_STEP)]
