"""The legged robot of the collision scene: its gait clock, and the balance of its forces."""

import math

import numpy as np
import pytest

from sim.shell import walk as shell_walk


def test_one_tripod_always_stands_and_the_cranks_turn_smoothly():
  walk = shell_walk.Walk()
  t = np.linspace(0.0, 3.0, 30001)  # 2.5 s of walking: whole strides
  a = shell_walk.crank_angle(walk, t)
  down = (a + math.pi) % (2 * math.pi) - math.pi  # from straight down, in [-pi, pi)
  stands = np.abs(down) <= walk.sweep + 1e-9
  assert np.all(stands.any(axis=1))
  # after the rest each tripod stands half of each stride, and turns once per stride
  walking = t >= walk.rest
  assert abs(stands[walking].mean() - 0.5) < 0.01
  assert abs((a[-1, 0] - a[0, 0]) - 2 * math.pi * walk.stride_hz * (t[-1] - walk.rest)) < 1e-6
  assert np.max(np.abs(np.diff(a, axis=0))) < 2 * math.pi * walk.stride_hz * 2 * 1e-4


def test_pushing_a_wall_the_feet_and_the_wall_balance():
  walk = shell_walk.Walk(wall="head_on", duration=5.0)
  r = shell_walk.simulate(walk)
  pushing = r.time > r.time[-1] - 2.0
  assert np.ptp(r.pose[pushing, 0]) < 2e-3  # stopped at the wall
  assert abs(r.pose[-1, 3]) < 0.05  # still square to it: chassis frame ~ world frame
  wall = r.contact[pushing, 0].mean()
  feet = r.feet[pushing].mean(axis=0)
  # momentum: over whole strides at rest the wall's push returns the feet's friction
  assert abs(wall + feet[0]) < 0.03 * abs(feet[0]), (wall, feet)
  # Coulomb: the friction never exceeds mu times the normal load
  assert abs(feet[0]) <= walk.friction * feet[2] * 1.01


def test_walking_freely_touches_nothing_and_repeats_itself():
  walk = shell_walk.Walk(wall="none", duration=1.5)
  a, b = shell_walk.simulate(walk), shell_walk.simulate(walk)
  assert not a.contact.any() and not a.touching.any()
  assert a.counts.tobytes() == b.counts.tobytes()
  # standing, the feet carry the weight
  rest = a.time < walk.rest
  assert abs(a.feet[rest, 2].mean() / walk.weight - 1) < 0.02


def test_walk_bad_input_is_named():
  with pytest.raises(ValueError, match="wall"):
    shell_walk.simulate(shell_walk.Walk(wall="door"))
  with pytest.raises(ValueError, match="weight"):
    shell_walk.simulate(shell_walk.Walk(weight=0.05))
  with pytest.raises(ValueError, match="sweep"):
    shell_walk.simulate(shell_walk.Walk(sweep=2.0))
