"""raw_streams: the footpad's recordings written as a real rig logs them, two raw streams per
recording, and calibrated through `calibrate merge` and `--tare` against the same
calibration on perfectly synchronised data.

Each recording (the training paths and the test paths of three sessions of one pad)
starts with the pad held off the plate for `rest` seconds, then runs its
CNC paths. Its die pressures go through the sensor chain again with that rest in front (the
recording's own noise and drift streams run on through it), so the unloaded lead-in is read
as the pad reads it. Two files per recording:
  - sensor: the counts every 11th 1 kHz sample (90.9 Hz), its clock starting at 0, each
    channel's baseline moved by a per-recording offset (a different mount, temperature or
    supply each day; `sensor_offset` counts rms);
  - reference: the plate's force at an irregular ~250 Hz (each period 2-6 ms), stamped `lag`
    seconds later than the sensor stamps the same event, with a per-recording offset
    (`reference_offset` N rms: an F/T sensor not biased before the run).
The calibrations: (1) "synchronised": counts and force at the same instants, no offsets:
the ideal; (2) "synchronised + tare": the same instants with the offsets, tared; (3) "merged
+ tare": `streams.merge` with the lag estimated from the data, then `prepare` tares each
recording on its first `tare` seconds; (4) the same with the lag given (what the estimate
costs); (5) "merged, no tare". Each is
fitted (LS and `auto`, grouped by recording) on the training recordings and scored on the
test recordings, themselves merged and tared by the same rule. The stream files land in
DIR/streams/ for `python -m calibrate merge` (the README walks through them).

Measured (--quick, seed 0, 3 sessions): merged + tare against synchronised + tare 0.97-0.99x
NRMSE on every axis (LS and auto): the merge costs nothing; the lag estimate 22.6-23.0 ms
for 25 ms (the known lag gives the same errors). Against the offset-free ideal the tare
wins on shear (auto X/Y 0.52/0.86x: it takes away each recording's drift start too) and
costs Z 11-16 %: only with both `thermal_drift` and `hysteresis` on (the chain re-run
without either: Z the same within 1 % tared or not). Without the tare the offsets cost Z
1.9x.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from benchmarks.registry import register
from util import fields
from util.fields import setting

STEP = 11  # 1 kHz samples per sensor sample: 90.9 Hz


@fields.declared
@dataclasses.dataclass(frozen=True)
class RawStreams:
  """Settings of the benchmark.

  Attributes:
    lag: how much later the reference stamps an event, s.
    rest: the unloaded lead-in of every recording, s.
    tare: the seconds the tare takes as unloaded (within the lead-in), s.
    sensor_offset: rms of each channel's per-recording baseline offset, counts.
    reference_offset: rms of the reference's per-recording offset per axis, N.
    epochs: epoch cap of `auto`'s networks.
    sessions: training sessions of the pad (each its own noise and drift draw; 1 is what
      the test suite has simulated already, for the README's walk-through).
  """
  lag: float = setting(0.025, "[0, 0.5]", "s")
  rest: float = setting(1.0, "[0.2, 10]", "s")
  tare: float = setting(0.8, "[0.05, 10]", "s")
  sensor_offset: float = setting(40.0, "[0, 1000]", "counts")
  reference_offset: float = setting(3.0, "[0, 100]", "N")
  epochs: int = setting(100, "[1, 10000]")
  sessions: int = setting(3, "[1, 8]")

  def relations(self):
    yield self.tare <= self.rest, "tare", f"at most rest ({self.rest:g} s)", self.tare


def settings(quick: bool, seed: int) -> RawStreams:
  return RawStreams()


def _with_rest(scene, rec, rest: float, seed: int):
  """(counts (N, D), force (N, 3)) of `rec` with `rest` seconds unloaded in front: its die
  pressures through the scene's sensor chain again, zero over the rest, on the recording's
  own noise and drift streams (so the drift runs on from the rest into the paths); the
  plate's force as recorded, and over the rest the F/T noise of the chain alone."""
  from sim.footpad import layer, scene as scene_lib, sensor_chain
  n = int(round(rest / scene.params.timestep))
  dies = rec.pressure.shape[1]
  stream = scene_lib.stream_of(scene_lib.episodes(scene, layer.die_kernel(
      scene.params, scene.kernel)), scene.session)
  pressure = np.vstack([np.zeros((n, dies)), rec.pressure])
  counts, _ = sensor_chain.apply(pressure, np.zeros((len(pressure), 6)), scene.effects,
                                 scene.seed, scene.adc, scene.params.timestep, stream)
  _, quiet = sensor_chain.apply(np.zeros((n, dies)), np.zeros((n, 6)), scene.effects, seed,
                                scene.adc, scene.params.timestep, stream)
  return counts, np.vstack([quiet[:, :3], rec.wrench[:, :3]])


def _recordings(ctx):
  """{name: (sensor stream, reference stream, synchronised counts, synchronised force, and
  that force with the reference's offset)} of the training and test recordings."""
  from calibrate import streams
  from sim.footpad import protocol, scene as scene_lib
  s = ctx.settings
  base = protocol.base(ctx.quick, ctx.seed)
  rng = np.random.default_rng(np.random.SeedSequence(ctx.seed, spawn_key=(24,)))
  out = {}
  # each session's training paths, then its test paths: another recording, its own noise
  # and drift (`stream_of`); one test recording is one draw of them, so every session gives
  # one and the test is their union
  for k, part in [(k, p) for p in ("train", "test") for k in range(s.sessions)]:
    name = f"{part}{k + 1}"
    scene = protocol.scenes(dataclasses.replace(base, session=k))[part]
    rec, _ = scene_lib.generate(scene, ctx.progress(f"footpad {name}"), ctx.use_cache)
    ctx.used(rec)
    counts, force = _with_rest(scene, rec, s.rest, ctx.seed + len(out))
    t = np.arange(len(counts)) * scene.params.timestep
    sensor, reference = streams.two_streams(
        t, counts, force, [f"p{i + 1}" for i in range(counts.shape[1])], ("Fx", "Fy", "Fz"),
        lag=s.lag, rng=rng, step=STEP, x_offset=s.sensor_offset,
        y_offset=s.reference_offset, x_units=("counts",) * counts.shape[1],
        y_units=("N",) * 3, name=name)
    # the same instants with the reference's offsets: what the merge is measured against
    offset = np.median(reference.data[:, 1:] - np.column_stack(
        [np.interp(reference.data[:, 0] - s.lag, t, f) for f in force.T]), axis=0)
    out[name] = (sensor, reference, counts[::STEP], force[::STEP], force[::STEP] + offset)
  return out


def _fit_and_score(x, y, rec, xt, yt, epochs: int, seed: int) -> dict:
  """LS and auto fitted on (x, y) grouped by `rec`, scored on (xt, yt)."""
  import warnings
  from calibrate import estimators, metrics, splits
  from calibrate.parts import mlp
  groups = splits.groups(len(x), "auto", rec, x)  # one recording: blocks of it
  folds = min(groups.count, 5)
  out = {}
  with warnings.catch_warnings():
    warnings.simplefilter("ignore", estimators.OutOfRangeWarning)
    ls = estimators.fit("LS", x, y, groups=groups, folds=folds)
    auto, _ = estimators.fit_auto(x, y, groups, folds, config=mlp.LMConfig(epochs=epochs),
                                  seed=seed)
    for method, est in (("LS", ls), ("auto", auto)):
      pred = est.predict(xt)
      out[method] = {"nrmse_pct": metrics.nrmse_pct(pred, yt).tolist(),
                     "r2_pct": metrics.r2_pct(pred, yt).tolist()}
    out["auto"]["chosen"] = auto.info.validation["chosen"]
  return out


@register("raw_streams", "the footpad's recordings as two raw streams (sensor at 90.9 Hz, "
          "reference at an irregular 250 Hz, a lag, offsets per recording) calibrated "
          "through merge and tare, against the same calibration on synchronised data",
          settings=settings, tags=("footpad", "calibration"))
def run(ctx):
  from benchmarks import outputs
  from calibrate import csvfile, metrics, prepare, streams
  s = ctx.settings
  recs = _recordings(ctx)
  folder = ctx.out / "streams"
  folder.mkdir(parents=True, exist_ok=True)
  merged, said = {}, []
  d = len(next(iter(recs.values()))[0].names) - 1
  tare = prepare.Steps(tare=prepare.Tare(seconds=s.tare))
  for name, (a, b, *_) in recs.items():
    csvfile.write(folder / a.path, a.names, a.data, a.units)
    csvfile.write(folder / b.path, b.names, b.data, b.units)
    m = streams.merge(a, b)
    said.append(m.describe(a.path))
    merged[name] = (m, csvfile.Table(m.names, m.units, m.data, a.path, m.lines))
    known = streams.merge(a, b, lag=s.lag)
    merged[f"{name} known lag"] = (known, csvfile.Table(known.names, known.units, known.data,
                                                        a.path, known.lines))
  cols = list(range(1, d + 1)), list(range(d + 1, d + 4))

  def stack(names, steps):
    ready = prepare.apply([merged[n][1] for n in names], *cols, steps)
    return ready.x, ready.y, ready.recording
  train = [n for n in recs if n.startswith("train")]
  test = [n for n in recs if n.startswith("test")]
  results = {}
  # (1) the ideal: the same instants in both, no offsets
  sync = [recs[n] for n in train]
  results["synchronised"] = _fit_and_score(
      np.vstack([r[2] for r in sync]), np.vstack([r[3] for r in sync]),
      np.concatenate([np.full(len(r[2]), k) for k, r in enumerate(sync)]),
      np.vstack([recs[n][2] for n in test]), np.vstack([recs[n][3] for n in test]),
      s.epochs, ctx.seed)
  # (2) the same instants with the offsets, tared: what the merge itself costs beside it
  for name in recs:
    sensor, _, _, _, force = recs[name]
    merged[name + " synchronised"] = (None, csvfile.Table(
        merged[name][1].names, merged[name][1].units, np.column_stack([sensor.data, force]),
        name))
  for label, steps, suffix in (("synchronised + tare", tare, " synchronised"),
                               ("merged + tare", tare, ""),
                               ("known lag + tare", tare, " known lag"),
                               ("merged, no tare", prepare.Steps(), "")):
    x, y, rec = stack([n + suffix for n in train], steps)
    xt, yt, _ = stack([n + suffix for n in test], steps)
    results[label] = _fit_and_score(x, y, rec, xt, yt, s.epochs, ctx.seed)
  lags = [merged[n][0].lag for n in recs]
  for line in said:
    ctx.print(line)
  ctx.print(f"lag estimated {min(lags) * 1e3:.1f}-{max(lags) * 1e3:.1f} ms (true "
            f"{s.lag * 1e3:.1f} ms; one sensor period {STEP:d} ms)")
  ctx.print(f"{'calibration':20s} {'method':6s} {'NRMSE % X':>10s} {'Y':>7s} {'Z':>7s}   "
            f"{'against synchronised':>20s}   {'against synchronised + tare':>27s}")
  for label, by_method in results.items():
    for method, r in by_method.items():
      ratios = [np.array(r["nrmse_pct"]) / np.array(results[ideal][method]["nrmse_pct"])
                for ideal in ("synchronised", "synchronised + tare")]
      ctx.print(f"{label:20s} {method:6s} " + " ".join(f"{v:7.2f}" for v in r["nrmse_pct"])
                + "   " + "   ".join(" ".join(f"{v:5.2f}x" for v in ratio)
                                     for ratio in ratios)
                + (f"   kept: {', '.join(r['chosen'])}" if "chosen" in r else ""))
  ctx.print(f"stream files in {folder}/ (python -m calibrate merge A_sensor.csv "
            f"A_reference.csv ...)")
  rows = metrics.scored("raw_streams", {f"{label} {m}": {ax: {k: r[k][j] for k in
                                                               ("nrmse_pct", "r2_pct")}
                                                          for j, ax in enumerate("XYZ")}
                                        for label, bm in results.items()
                                        for m, r in bm.items()})
  rows += [outputs.Row("raw_streams", "", "", "lag_estimated_s", v) for v in lags]
  return outputs.Result({"results": results, "lags_s": lags, "merged": said}, tuple(rows))
