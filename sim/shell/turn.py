"""The turn scene: a 50 g mass on the shell while the robot turns through the paper's sequence
(shell paper Sec. III-B, Figs. 8-9).

Legs down (A), nose up (B), legs up (C), nose down (D), legs down (E), left side down (F),
legs up (G), left side up (H), legs down (I): a full slow turn about the robot's y axis, then
one about x. Turning slowly is simulated by turning gravity in the chassis frame (the F/T body
stays put), `TURN_SECONDS` per turn.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from sim.shell import scene as shell

PAYLOAD = 0.05  # kg, the paper's mass
TURN_SECONDS = 10.0


def gravity_sequence(steps_per_turn: int, g: float = 9.81) -> np.ndarray:
  """(2 * steps_per_turn, 3) gravity in the chassis frame: a turn about y, then about x,
  starting legs down (gravity along -z)."""
  a = np.linspace(0, 2 * np.pi, steps_per_turn, endpoint=False)
  about_y = np.column_stack([g * np.sin(a), np.zeros_like(a), -g * np.cos(a)])
  about_x = np.column_stack([np.zeros_like(a), -g * np.sin(a), -g * np.cos(a)])
  return np.concatenate([about_y, about_x])


def simulate(board: shell.ShellScene, seed: int) -> tuple[np.ndarray, np.ndarray]:
  """Frames at 100 Hz: (counts (F, 8), gravity in the chassis frame (F, 3)), on the board and
  with the effects of `board` (the calibration's)."""
  loaded = dataclasses.replace(board, params=dataclasses.replace(board.params, payload=PAYLOAD))
  model = shell.compile_checked(loaded.spec(), "shell turn", loaded.params)
  data = mujoco.MjData(model)
  dt = model.opt.timestep
  # the model's own gravity, whatever its magnitude (9.81 m/s^2 unless the spec says otherwise)
  grav = gravity_sequence(int(round(TURN_SECONDS / dt)), float(np.linalg.norm(model.opt.gravity)))
  spf = shell.frame_steps(dt)
  shell.run_frames("shell turn", model, data, 1000, 1000)  # settle legs down, the mass on

  def set_gravity(i: int) -> None:
    model.opt.gravity[:] = grav[i]

  pose, _ = shell.run_frames("shell turn", model, data, len(grav), spf, set_gravity)
  _, counts = shell.sense(board, pose, seed)
  return counts, grav[spf - 1::spf]
