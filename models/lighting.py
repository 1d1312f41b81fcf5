"""Lights and an offscreen buffer for the rigs' specs, so a render shows them lit (physics
is untouched: lights and visual settings enter no equation of motion)."""

from __future__ import annotations

import mujoco

OFFSCREEN = (1280, 960)  # px: the largest image `sim.render` draws


def light(spec: mujoco.MjSpec, height: float) -> None:
  """A soft headlight and a directional key light from above and in front (`height`, m,
  above the rig's origin), plus an offscreen buffer of `OFFSCREEN` pixels."""
  spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
  spec.visual.headlight.diffuse = [0.45, 0.45, 0.45]
  spec.visual.headlight.specular = [0.1, 0.1, 0.1]
  spec.visual.global_.offwidth, spec.visual.global_.offheight = OFFSCREEN
  spec.worldbody.add_light(name="key", pos=[0.3 * height, -0.6 * height, height],
                           dir=[-0.3, 0.6, -1.0], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                           diffuse=[0.6, 0.6, 0.6], specular=[0.2, 0.2, 0.2], castshadow=False)
