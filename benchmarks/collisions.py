"""collisions: the robot walking freely, into a wall corner-first, and head-on (paper Fig. 11).

Three episodes of `sim.shell_walk` (2 Hz stride, thrust at most 0.49 N): no wall, a wall
turned 45 degrees met by the shell's front-left corner, and a wall square across the path.
The shell's counts at 100 Hz are read through the cubic calibration of `shell_table1`; the
contact force the wall puts on the shell (from MuJoCo's contacts, chassis frame) is printed
beside it as truth, and both beside the paper's: +-0.15 N while walking, about -0.2 N in Fx
and Fy at the corner (the robot then turns right), a -0.5 N Fx spike head-on, the thrust.
`--set` takes `ShellScene` fields for the calibration and the shell (params.*).
"""

from __future__ import annotations

import numpy as np

from benchmarks import shell_data
from sim import shell_walk

DESCRIPTION = "shell walking into a corner and a wall: force signs and sizes vs paper Fig. 11"
PAPER = {"walking_amplitude": 0.15, "corner_fx": -0.2, "corner_fy": -0.2, "head_on_fx": -0.5}


def run(ctx) -> dict:
  cal = shell_data.calibrated(ctx)
  board, est = cal.board, cal.estimator
  out = {}
  for wall in shell_walk.WALLS:
    r = shell_walk.simulate(shell_walk.Walk(board=board, wall=wall, seed=ctx.seed))
    f = est.predict(r.counts)
    walking = (r.time > 0.5) & (r.time < 1.5)  # before any wall
    last = r.time > r.time[-1] - 1.0
    out[wall] = {
        "walking_amplitude": (np.ptp(f[walking, :3], axis=0) / 2).tolist(),
        "min": f[:, :3].min(axis=0).tolist(), "contact_min": r.contact[:, :3].min(axis=0).tolist(),
        "steady": f[last, :3].mean(axis=0).tolist(),
        "contact_steady": r.contact[last, :3].mean(axis=0).tolist(),
        "final_yaw_deg": float(np.degrees(r.pose[-1, 3]))}
  w = out["none"]["walking_amplitude"]
  ctx.print(f"walking freely: Fx, Fy, Fz +-{w[0]:.3f}, {w[1]:.3f}, {w[2]:.3f} N (paper +-0.15 N)")
  c = out["corner"]
  ctx.print(f"corner: Fx min {c['min'][0]:+.3f} N (contact {c['contact_min'][0]:+.3f}), Fy min "
            f"{c['min'][1]:+.3f} N (contact {c['contact_min'][1]:+.3f}); paper about -0.2 N "
            f"each; yaw after {c['final_yaw_deg']:+.1f} deg (paper: turns right, i.e. < 0)")
  h = out["head_on"]
  ctx.print(f"head-on: Fx spike {h['min'][0]:+.3f} N (contact {h['contact_min'][0]:+.3f}), "
            f"pushing {h['steady'][0]:+.3f} N (contact {h['contact_steady'][0]:+.3f}); paper "
            f"-0.5 N, the robot's largest thrust")
  return {"results": out, "paper": PAPER}
