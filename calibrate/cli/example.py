"""`python -m calibrate example`: the example recordings (the simulated footpad)."""

from __future__ import annotations

import pathlib

import numpy as np

from calibrate import csvfile
from util import cli, files


def add_parser(sub) -> None:
  p = sub.add_parser("example", help="write the example recordings (the simulated footpad)",
                     description="Copies the example recordings shipped with the package: the "
                                 "simulated footpad's quick protocol at seed 0, every 20th "
                                 "sample. 'python -m benchmarks.run footpad_dataset --quick' "
                                 "writes them afresh from the simulator, to its results "
                                 "folder's csv/.")
  p.add_argument("out", type=cli.path_arg, help="folder for train.csv and test.csv")
  p.add_argument("--streams", action="store_true",
                 help="write them instead as raw stream pairs, as a rig logs them (for "
                      "`merge` and `fit --tare`): the training recording cut in three, each "
                      "with 1 s at rest in front, the sensor's baseline and the reference's "
                      "offset moved per recording, the reference at an irregular 250 Hz "
                      "stamped 25 ms late: trainK_sensor.csv, trainK_reference.csv, "
                      "test_sensor.csv, test_reference.csv")


EXAMPLES = pathlib.Path(__file__).parents[1] / "examples"



def run(args) -> int:
  return files.holding(args.out, "the example folder", lambda _: _example(args))


def _example(args) -> int:
  written = []
  if args.streams:
    written = streams_pairs(args.out)
  else:
    for name in ("train.csv", "test.csv"):
      files.write_text(args.out / name, (EXAMPLES / name).read_text())
      written.append(args.out / name)
  for path in written:
    print(f"wrote {path}")
  return 0


EXAMPLE_LAG = 0.025  # s: how late the example reference stamps an event

EXAMPLE_REST = 1.0  # s at rest in front of every example stream recording



LEAN = 600.0  # N on Fz for 0.3 s: someone leaning on the plate
KNOCK = 0.6  # s after the sensor's sharpest event: when train2's reference logs a lean
DROPOUTS = 3  # reference dropouts of 50-150 ms per recording


def streams_pairs(out: pathlib.Path) -> list[pathlib.Path]:
  """The example recordings as raw stream pairs (`example --streams`): a demonstration of
  the commands, made from the 50 Hz example (the reference is interpolated from it);
  `python -m benchmarks.run raw_streams` measures the same steps on 1 kHz simulator data.
  What a real log holds, planted: units in the column names (`p1 [counts]`, `F_x [N]`), a
  reference clock at an irregular 167-500 Hz with `DROPOUTS` dropouts per recording, and in
  train2's reference a lean on the plate (60 N for 0.3 s, `KNOCK` s after the sensor's
  sharpest event) that the pad never felt, on which that pair's lag estimate locks."""
  from calibrate import streams
  rng = np.random.default_rng(np.random.SeedSequence(0, spawn_key=(24,)))
  written = []
  # the pad at rest: the training recording's least loaded row (|F| 0.1 N; the test paths
  # never unload)
  train = csvfile.read(EXAMPLES / "train.csv")
  rest = train.data[np.argmin(np.linalg.norm(train.data[:, -3:], axis=1)), 1:-3]
  for part, pieces in (("train", 3), ("test", 1)):
    table = csvfile.read(EXAMPLES / f"{part}.csv")
    ins, outs = table.columns(["p*"], "p*"), table.columns(["Fx", "Fy", "Fz"], "F")
    t = table.column("time")
    dt = float(np.median(np.diff(t)))
    # cut where the pad is least loaded near each third: a recording starts off the plate
    load = np.linalg.norm(table.data[:, outs], axis=1)
    w = len(t) // 10
    cuts = [int(c - w + np.argmin(load[c - w:c + w])) for c in
            (len(t) * np.arange(1, pieces) // pieces)]
    for k, rows in enumerate(np.split(np.arange(len(t)), cuts)):
      n = int(round(EXAMPLE_REST / dt))
      x = np.vstack([np.round(rest + rng.normal(0, 1.5, (n, len(ins)))),
                     table.data[rows][:, ins]])
      y = np.vstack([rng.normal(0, 0.1, (n, len(outs))), table.data[rows][:, outs]])
      name = f"{part}{k + 1}" if pieces > 1 else part
      sensor, reference = streams.two_streams(
          np.arange(len(x)) * dt, x, y, [f"{table.names[i]} [counts]" for i in ins],
          ["F_x [N]", "F_y [N]", "F_z [N]"], lag=EXAMPLE_LAG, rng=rng, x_offset=40.0,
          y_offset=3.0, name=name)
      sensor, reference = _logged(sensor, reference, rng, knock=name == "train2")
      for one in (sensor, reference):
        written.append(csvfile.write(out / one.path, one.names, one.data))
  return written


def _logged(sensor, reference, rng, knock: bool):
  """(sensor, reference) as their loggers kept them: the reference with `DROPOUTS` gaps of
  50-150 ms; with `knock`, someone leaning on the plate (`LEAN` on Fz for 0.3 s, `KNOCK` s
  after the sensor's sharpest event) while the sensor's logger paused (a USB hiccup: its
  rows from 0.1 s before to 0.1 s after the lean are missing), so no merged row holds the
  lean and only the lag estimate sees it."""
  t = reference.data[:, 0]
  keep = np.ones(len(t), bool)
  for start in rng.uniform(t[0] + 2, t[-1] - 1, DROPOUTS):
    keep &= ~((t > start) & (t < start + rng.uniform(0.05, 0.15)))
  data = reference.data[keep].copy()
  if not knock:
    return sensor, csvfile.Table(reference.names, reference.units, data, reference.path)
  rate = np.linalg.norm(np.diff(sensor.data[:, 1:], axis=0), axis=1)
  when = sensor.data[np.argmax(rate) + 1, 0] + EXAMPLE_LAG + KNOCK  # on the reference's clock
  data[(data[:, 0] >= when) & (data[:, 0] < when + 0.3), -1] += LEAN
  ts = sensor.data[:, 0] + EXAMPLE_LAG
  paused = (ts > when - 0.1) & (ts < when + 0.4)
  return (csvfile.Table(sensor.names, sensor.units, sensor.data[~paused], sensor.path),
          csvfile.Table(reference.names, reference.units, data, reference.path))
