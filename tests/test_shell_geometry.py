"""The shell's reflector geometry and mount against the paper's Eqn 3 and closed forms."""

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from models import shell
from sim.shell import geometry as geo

P = shell.ShellParams()


@pytest.fixture(scope="module")
def rig():
  model = shell.build_spec(P).compile()
  return model, mujoco.MjData(model)


def test_ray_heights_equal_closed_form(rig):
  model, data = rig
  rng = np.random.default_rng(0)
  centre = shell.elastic_centre(P)
  rest = None
  for _ in range(20):
    q = np.concatenate([rng.uniform(-4e-4, 4e-4, 3), rng.uniform(-0.02, 0.02, 3)])
    if rest is None:
      geo.rays_at(model, data, np.zeros(6))
      rest = data.body("shell").xpos.copy()
    rays = geo.rays_at(model, data, q)
    body = data.body("shell")
    closed = geo.heights(P, body.xmat.reshape(3, 3), body.xpos - rest, centre=centre)
    np.testing.assert_allclose(rays, closed, rtol=0, atol=1e-9)


def test_simulated_height_map_is_eqn3():
  """d(ray heights)/d(mount joints), moved from the elastic centre to the centre of the
  reflector plane (the paper's small-angle derivation), equals Eqn 3."""
  jac = geo.ray_jacobian(P)
  ref = shell.eqn3_matrix(P)
  np.testing.assert_allclose(jac, ref, rtol=0,
                             atol=1e-3 * np.max(np.abs(ref)))
  np.testing.assert_allclose(geo.height_jacobian(P), ref, rtol=0,
                             atol=1e-6 * np.max(np.abs(ref)))


@pytest.mark.parametrize("cx, cy, rank", [(0.3, 0.3, 6), (0.0, 0.3, 5), (0.3, 0.0, 4),
                                          (0.0, 0.0, 3)])
def test_rank_follows_the_slopes(cx, cy, rank):
  q = geo.map_quality(geo.height_jacobian(dataclasses.replace(P, slope_x=cx, slope_y=cy)))
  assert q.rank == rank
  assert len(q.lost) == 6 - rank
  assert math.isfinite(q.condition) == (rank == 6)
  if cx == 0 and cy != 0:
    assert "x" in q.lost[0].split()  # the lost direction is sideways x


def test_condition_improves_with_slope():
  conds = [geo.map_quality(geo.height_jacobian(dataclasses.replace(P, slope_x=c, slope_y=c)))
           .condition for c in (0.02, 0.1, 0.5)]
  assert conds[0] > conds[1] > conds[2]


def test_preload_holds_the_design_gap_under_gravity():
  model = shell.build_spec(P).compile()
  data = mujoco.MjData(model)
  for _ in range(3000):
    mujoco.mj_step(model, data)
  np.testing.assert_allclose(geo.ray_heights(model, data), P.gap, atol=1e-7)


def test_vertical_ring_with_50_g_is_the_spring_mass_frequency():
  params = dataclasses.replace(P, payload=0.05, damping_ratio=0.0)
  model = shell.build_spec(params).compile()
  data = mujoco.MjData(model)
  model.opt.gravity[:] = 0
  z = model.joint("mount_z")
  data.qpos[z.qposadr[0]] = 1e-4
  trace = []
  for _ in range(2000):
    mujoco.mj_step(model, data)
    trace.append(data.qpos[z.qposadr[0]] - model.qpos_spring[z.qposadr[0]])
  trace = np.array(trace)
  up = np.flatnonzero((trace[:-1] < 0) & (trace[1:] >= 0))
  measured = (len(up) - 1) / ((up[-1] - up[0]) * model.opt.timestep)
  mass = model.body("shell").subtreemass[0]
  expected = math.sqrt(shell.mount_stiffness(params)[2] / mass) / (2 * math.pi)
  assert measured == pytest.approx(expected, rel=0.05)


def test_mount_stiffness_axial_terms():
  k = shell.mount_stiffness(P)
  xy = np.array(P.spring_xy)
  assert k[2] == pytest.approx(4 * P.spring_rate)
  # rotations: each spring's axial rate at its lever plus a small bending share
  assert k[3] == pytest.approx(P.spring_rate * np.sum(xy[:, 1] ** 2), rel=0.1)
  assert k[4] == pytest.approx(P.spring_rate * np.sum(xy[:, 0] ** 2), rel=0.1)
  assert k[3] > P.spring_rate * np.sum(xy[:, 1] ** 2)


@pytest.mark.parametrize("change, message", [
    (dict(spring_rate=-150.0), "spring_rate"),
    (dict(gap=0.006), "gap"),
    (dict(sensor_x=(0.0,) * 7), "sensor_x"),
])
def test_bad_parameters_are_named(change, message):
  with pytest.raises(ValueError, match=message):
    shell.build_spec(dataclasses.replace(P, **change))


def test_finite_facets_miss_where_rays_miss(rig):
  model, data = rig
  rng = np.random.default_rng(5)
  centre = shell.elastic_centre(P)
  geo.rays_at(model, data, np.zeros(6))
  rest = data.body("shell").xpos.copy()
  misses = 0
  # (the shell kept above the PCB: a ray from the aperture cannot see a facet below it)
  for _ in range(200):
    q = np.concatenate([rng.uniform(-3e-3, 3e-3, 2), rng.uniform(-1.5e-3, 1.5e-3, 1),
                        rng.uniform(-0.05, 0.05, 3)])
    rays = geo.rays_at(model, data, q)
    body = data.body("shell")
    closed = geo.heights(P, body.xmat.reshape(3, 3), body.xpos - rest, centre=centre,
                         finite_facets=True)
    np.testing.assert_array_equal(np.isnan(rays), np.isnan(closed))
    np.testing.assert_allclose(rays[~np.isnan(rays)], closed[~np.isnan(closed)], atol=1e-9)
    misses += np.isnan(rays).sum()
  assert misses > 20  # the poses do reach past the facets
