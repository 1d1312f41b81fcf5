"""collisions: the robot walks, hits a wall corner-first, follows it and meets a perpendicular
wall (paper Sec. III-D, Fig. 11).

One `sim.shell.walk` episode on the "course": at rest [I], walking at a 2 Hz stride, the
shell's front-left corner meeting a side wall that closes in at 20 degrees [II], walking
along it [III], and pushing into the wall across its path [IV]. The shell's counts at
100 Hz are read through the cubic calibration of `shell_table1`. Beside them, as truth: the
force the walls put on the shell (MuJoCo's contacts, chassis frame) and, while walking
freely, the mount's spring force K (q - q_rest), which is what an ideal shell reads when the
body's jolts shake it. The paper's numbers: +-0.15 N while walking, a spike of about -0.2 N
in Fx and Fy at the corner, the robot then turning right, a negative Fy along the wall, and
a -0.5 N Fx spike at the perpendicular wall, the robot's largest thrust (mu_s 0.7 x 0.7 N),
after which Fx swings between -0.2 and -0.5 N at the stride frequency.
`--set` takes `ShellScene` fields for the calibration and the shell (params.*).
"""

from __future__ import annotations

import numpy as np

from benchmarks import shell
from benchmarks.registry import register
from util import files

PAPER = {"walking_amplitude": 0.15, "corner_fx": -0.2, "corner_fy": -0.2, "turn": "right",
         "end_wall_spike": -0.5, "pushing_range": [-0.5, -0.2]}
DURATION = 9.0  # s: about 3 s of walking, 2 s along the side wall, 3 s against the end wall
CORNER = 0.3  # s after the first touch that count as the corner hit


def phases(run, walk) -> dict[str, np.ndarray]:
  """Frame masks of the paper's sections: rest [I], walking before any wall, the corner hit
  [II], along the side wall [III] and against the end wall [IV] (its first second is the
  impact; `pushing` is the rest), of a `sim.shell.walk.WalkRun` of `walk`."""
  t = run.time
  side = np.flatnonzero(run.touching & 1)
  end = np.flatnonzero(run.touching & 2)
  t_side = t[side[0]] if len(side) else np.inf
  t_end = t[end[0]] if len(end) else np.inf
  return {
      "rest": t < walk.rest,
      "walking": (t > walk.rest + 0.5) & (t < t_side),
      "corner": (t >= t_side) & (t < t_side + CORNER),
      "along": (t >= t_side + CORNER) & (t < t_end),
      "end_wall": (t >= t_end) & (t < t_end + 1.0),
      "pushing": t >= t_end + 1.0,
  }


def _stride_extremes(f: np.ndarray, t: np.ndarray, stride: float) -> tuple[float, float]:
  """Median over whole strides of each stride's (max, min) of f."""
  k = np.floor((t - t[0]) / stride).astype(int)
  whole = [j for j in np.unique(k) if np.sum(k == j) >= 0.9 * stride / (t[1] - t[0])]
  if not whole:
    return float("nan"), float("nan")
  return (float(np.median([f[k == j].max() for j in whole])),
          float(np.median([f[k == j].min() for j in whole])))


@register("collisions", "shell robot walking into a wall corner-first and head-on: force traces "
          "vs Fig. 11", settings=shell.protocol_settings,
          presets=shell.presets, fixed=shell.FIXED,
          tags=("shell", "paper", "dynamics"))
def run(ctx):
  from models import shell as model_lib
  from sim.shell import walk as walk_lib
  cal = shell.calibrated(ctx)
  walk = walk_lib.Walk(board=cal.board, wall="course", duration=DURATION, seed=ctx.seed)
  r = walk_lib.simulate(walk)
  f = cal.estimator.predict(r.counts)
  m = phases(r, walk)
  spring = model_lib.mount_stiffness(walk.board.params) * (r.mount - r.mount[m["rest"]].mean(0))
  if not (m["corner"].any() and m["along"].any() and m["pushing"].any()):
    raise RuntimeError("the robot did not reach both walls: lengthen DURATION or check the "
                       "walk's speed")
  yaw = np.degrees(r.pose[:, 3])
  stride = 1.0 / walk.stride_hz
  push_hi, push_lo = _stride_extremes(f[m["pushing"], 0], r.time[m["pushing"]], stride)
  out = {
      "walking_amplitude": (np.ptp(f[m["walking"], :3], axis=0) / 2).tolist(),
      "walking_spring_amplitude": (np.ptp(spring[m["walking"], :3], axis=0) / 2).tolist(),
      "walking_speed": float(np.ptp(r.pose[m["walking"], 0]) / np.ptp(r.time[m["walking"]])),
      "corner_min": f[m["corner"], :3].min(axis=0).tolist(),
      "corner_contact_min": r.contact[m["corner"], :3].min(axis=0).tolist(),
      "turn_deg": float(yaw[m["along"]][-1] - yaw[m["corner"]][0]),
      "along_mean": f[m["along"], :3].mean(axis=0).tolist(),
      "along_contact_mean": r.contact[m["along"], :3].mean(axis=0).tolist(),
      "end_wall_min": f[m["end_wall"], :3].min(axis=0).tolist(),
      "end_wall_contact_min": r.contact[m["end_wall"], :3].min(axis=0).tolist(),
      "pushing_mean": f[m["pushing"], :3].mean(axis=0).tolist(),
      "pushing_contact_mean": r.contact[m["pushing"], :3].mean(axis=0).tolist(),
      "pushing_stride_range": [push_lo, push_hi],
      "feet_friction_limit": float(walk.friction * walk.weight),
  }
  ctx.out.mkdir(parents=True, exist_ok=True)
  files.atomic_write(ctx.out / "course.npz", lambda out: np.savez(
      out, time=r.time, shell=f, contact=r.contact, spring=spring, pose=r.pose, crank=r.crank,
      touching=r.touching))
  _print(ctx, out)
  _figure(ctx, r, f, m, yaw)
  return _result(out)


# per-axis (Fx, Fy, Fz) lists of the results: {key: (method, metric)}
_PER_AXIS = {
    "walking_amplitude": ("shell", "walking_amplitude"),
    "walking_spring_amplitude": ("springs", "walking_amplitude"),
    "corner_min": ("shell", "corner_min"), "corner_contact_min": ("contact", "corner_min"),
    "along_mean": ("shell", "along_mean"), "along_contact_mean": ("contact", "along_mean"),
    "end_wall_min": ("shell", "end_wall_min"),
    "end_wall_contact_min": ("contact", "end_wall_min"),
    "pushing_mean": ("shell", "pushing_mean"),
    "pushing_contact_mean": ("contact", "pushing_mean")}


def _result(out: dict):
  """The course's numbers as rows: each per-axis force with its axis and its source (the
  calibrated shell, the walls' contact truth, the mount springs) as the method."""
  from benchmarks import outputs
  by_method: dict = {}
  for key, (method, metric) in _PER_AXIS.items():
    for ax, v in zip(("Fx", "Fy", "Fz"), out[key]):
      by_method.setdefault(method, {}).setdefault(ax, {})[metric] = v
  data = {"results": out, "paper": PAPER}
  rows = outputs.scored("course", by_method)
  return outputs.Result(data, tuple(rows + outputs.plain(
      data, skip=tuple(("results", k) for k in _PER_AXIS))))


def _print(ctx, out: dict) -> None:
  """The course's phases (I-IV) against the paper's Fig. 11."""
  a, s = out["walking_amplitude"], out["walking_spring_amplitude"]
  push_lo, push_hi = out["pushing_stride_range"]
  ctx.print(f"[I-II] walking at {out['walking_speed']:.3f} m/s: Fx, Fy, Fz +-{a[0]:.3f}, "
            f"{a[1]:.3f}, {a[2]:.3f} N (springs +-{s[0]:.3f}, {s[1]:.3f}, {s[2]:.3f}); "
            "paper +-0.15 N")
  c, cc = out["corner_min"], out["corner_contact_min"]
  ctx.print(f"[II] corner: Fx {c[0]:+.3f} N (contact {cc[0]:+.3f}), Fy {c[1]:+.3f} N (contact "
            f"{cc[1]:+.3f}); paper about -0.2 N each")
  ctx.print(f"[II-III] turn {out['turn_deg']:+.1f} deg ({'right' if out['turn_deg'] < 0 else 'left'}"
            f"; paper: right); along the wall Fy mean {out['along_mean'][1]:+.3f} N (contact "
            f"{out['along_contact_mean'][1]:+.3f}; paper: negative expected)")
  e, ec = out["end_wall_min"], out["end_wall_contact_min"]
  ctx.print(f"[IV] end wall: Fx spike {e[0]:+.3f} N (contact {ec[0]:+.3f}); pushing "
            f"{out['pushing_mean'][0]:+.3f} N (contact {out['pushing_contact_mean'][0]:+.3f}; "
            f"mu_s x weight {out['feet_friction_limit']:.3f}), per stride from "
            f"{push_lo:+.3f} to {push_hi:+.3f} N (medians); paper -0.5 N spike, then -0.5 to "
            "-0.2 N at the stride frequency")


def _figure(ctx, r, f: np.ndarray, m: dict, yaw: np.ndarray) -> None:
  """figures/course.png: the shell's and the walls' forces and the yaw along the course."""
  from benchmarks import figures
  groups = {f"F{ax}": {"shell (calibrated)": f[:, i], "walls' contact": r.contact[:, i]}
            for i, ax in enumerate("xyz")}
  groups["yaw"] = {"robot": yaw}
  spans = [(float(r.time[m[k]][0]), float(r.time[m[k]][-1]), label)
           for k, label in (("corner", "II corner"), ("along", "III along"),
                            ("pushing", "IV pushing")) if m[k].any()]
  figures.save(figures.traces(r.time, groups, {**dict.fromkeys(groups, "N"), "yaw": "deg"},
                              benchmark=ctx.name, seed=ctx.seed, spans=spans,
                              what="shell force along the course (shell paper Fig. 11)"),
               ctx.out, "course")
  ctx.print(f"traces: {ctx.out / 'course.npz'}, figure: {ctx.out / 'figures' / 'course.png'}")
