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
  files.output_folder(args.out, "the example folder")
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



def streams_pairs(out: pathlib.Path) -> list[pathlib.Path]:
  """The example recordings as raw stream pairs (`example --streams`): a demonstration of
  the commands, made from the 50 Hz example (the reference is interpolated from it);
  `python -m benchmarks.run raw_streams` measures the same steps on 1 kHz simulator data."""
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
      pair = streams.two_streams(np.arange(len(x)) * dt, x, y,
                                 [table.names[i] for i in ins], [table.names[i] for i in outs],
                                 lag=EXAMPLE_LAG, rng=rng, x_offset=40.0, y_offset=3.0,
                                 x_units=[table.units[i] for i in ins],
                                 y_units=[table.units[i] for i in outs], name=name)
      for one in pair:
        written.append(csvfile.write(out / one.path, one.names, one.data, one.units))
  return written
