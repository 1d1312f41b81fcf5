"""A run's physics held: checks every scene makes before and after stepping MuJoCo.

A diverged run never reports numbers. When MuJoCo finds a NaN or a huge acceleration it
prints a warning, counts it in `data.warning` and resets the state to the model's rest, then
goes on stepping: a run left unchecked records the reset rig as if it were data (measured: a
39,000 N test range for 1 N hand loads at spring_rate=1e4). So every scene calls `check`
after each chunk of steps, and `check_explicit_springs` refuses, before simulating, the
stiffness and step combinations that cannot be stable.
"""

from __future__ import annotations

from typing import Optional, Sequence

import mujoco
import numpy as np

from util.errors import SimulationError

# warnings after which the recorded state is not the physics of the scene
DIVERGED = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
            mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_CONTACTFULL,
            mujoco.mjtWarning.mjWARN_CNSTRFULL)

# semi-implicit Euler (MuJoCo's integrators treat joint stiffness explicitly) is stable for
# omega dt < 2; at 1 its frequency is already 4 % off, so that is the limit this project keeps
OMEGA_DT_LIMIT = 1.0


def check(data: mujoco.MjData, scene: str, hint: str,
          times: Optional[np.ndarray | tuple[float, float]] = None,
          values: Sequence[np.ndarray] = ()) -> None:
  """Raise SimulationError if MuJoCo warned since `data` was made or reset, or the run's
  recorded `values` are not finite.

  Args:
    data: the MjData the chunk of steps ran in (rollouts step in it too).
    scene: what ran, for the message (e.g. "shell calibration, session 1").
    hint: the setting to change, for the message.
    times: when the chunk ran, to date a divergence: the (T,) simulated time of each
      recorded step (a diverged step shows as the time falling back: MuJoCo resets the
      state), or the chunk's (start, end) in the scene's time (data.time restarts at 0).
    values: recorded arrays to check for NaN and inf.
  """
  warned = [w for w in DIVERGED if data.warning[w].number]
  finite = all(np.isfinite(v).all() for v in values)
  if not warned and finite:
    return
  when = f"at t={float(data.time):.4g} s"
  if isinstance(times, tuple):
    when = f"between t={times[0]:.4g} and {times[1]:.4g} s"
  elif times is not None and len(times) > 1:
    back = np.flatnonzero(np.diff(times) < 0)
    if len(back):
      when = f"at t={float(times[back[0]]):.4g} s"
  what = (f"MuJoCo warning {warned[0].name.removeprefix('mjWARN_')}" if warned
          else "a non-finite state")
  raise SimulationError(f"{scene}: the physics diverged ({what}) {when}: {hint}")


def check_explicit_springs(model: mujoco.MjModel, dofs: np.ndarray, scene: str,
                           setting: str) -> float:
  """Refuse a model whose stiffest spring mode is too fast for its step; returns omega dt.

  The modes are the generalised eigenvalues of the joint stiffness over the degrees of
  freedom `dofs` and their effective mass at the model's rest pose, every other degree of
  freedom left free (the Schur complement: a free chassis moves against the shell).

  Raises:
    SimulationError naming `setting` when omega dt > OMEGA_DT_LIMIT.
  """
  data = mujoco.MjData(model)
  mujoco.mj_forward(model, data)
  full = np.zeros((model.nv, model.nv))
  mujoco.mj_fullM(model, data, full)
  rest = np.setdiff1d(np.arange(model.nv), dofs)
  mass = full[np.ix_(dofs, dofs)]
  if len(rest):
    mass = mass - full[np.ix_(dofs, rest)] @ np.linalg.solve(full[np.ix_(rest, rest)],
                                                             full[np.ix_(rest, dofs)])
  stiff = np.diag(model.jnt_stiffness[model.dof_jntid[dofs]])
  omega = float(np.sqrt(np.max(np.linalg.eigvals(np.linalg.solve(mass, stiff)).real)))
  omega_dt = omega * model.opt.timestep
  if omega_dt > OMEGA_DT_LIMIT:
    raise SimulationError(
        f"{scene}: {setting} gives a spring mode of {omega / (2 * np.pi):.0f} Hz, too fast "
        f"for the {model.opt.timestep * 1e3:g} ms step (omega dt = {omega_dt:.2f}; the "
        f"explicit springs need <= {OMEGA_DT_LIMIT:g} and diverge at 2): lower it, or "
        f"params.timestep")
  return omega_dt
