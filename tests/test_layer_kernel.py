"""The die-stress kernels against elastic closed forms and equilibrium."""

import dataclasses

import numpy as np
import pytest

from models.footpad import FootpadParams
from sim.footpad import layer, scene as footpad


def _graded(half, fine, n_fine, n_coarse):
  core = np.linspace(0, fine, n_fine + 1)
  r = (half / fine) ** (1 / n_coarse)
  return np.concatenate([core, fine * r ** np.arange(1, n_coarse + 1)])


def _point_load_ratio(thickness, depth=0.005):
  """FE pressure under a small central patch over the Boussinesq point-load value."""
  xs = _graded(max(3 * thickness, 0.03), 0.003, 6, 8)
  zf = np.linspace(0, 0.006, 13)
  zs = zf if thickness <= 0.006 else np.concatenate(
      [zf, 0.006 * (thickness / 0.006) ** (np.arange(1, 7) / 6)])
  # quarter model: a 1x1 mm patch of total force 1 N -> 1/4 N on the quarter patch
  loads = layer.patch_loads(xs, xs, len(zs), [(0, 0.0005, 0, 0.0005)]) / 4
  sol = layer.solve_block(xs, xs, zs, 0.49, loads, symmetric_xy=True)
  fe = -sol.stress_zz(np.array([[0, 0, depth]]))[0, 2]
  ref = layer.boussinesq_cerruti(np.array([[0, 0, depth]]), np.zeros((1, 2)))[0, 0, 2]
  return fe / ref


def test_boussinesq_closed_form():
  # 3 P / (2 pi z^2) directly below a point load
  p = layer.boussinesq_cerruti(np.array([[0, 0, 0.005]]), np.zeros((1, 2)))[0, 0]
  assert p[2] == pytest.approx(3 / (2 * np.pi * 0.005**2), rel=1e-12)
  assert p[0] == p[1] == 0


@pytest.mark.slow
def test_thick_layer_tends_to_boussinesq():
  thin, thick, thicker = (_point_load_ratio(h) for h in (0.006, 0.024, 0.048))
  assert thin > 1.2  # a thin bonded layer concentrates stress over its rigid base
  assert abs(thicker - thick) < 0.01  # converged with thickness...
  assert abs(thicker - 1) < 0.05  # ...to the half-space (FE discretisation ~3 %)


@pytest.fixture(scope="module")
def real_layer():
  p = FootpadParams()
  mesh = layer.LayerMesh()
  xs = np.linspace(-p.footprint[0] / 2, p.footprint[0] / 2, p.grid[0] * mesh.subdivisions + 1)
  ys = np.linspace(-p.footprint[1] / 2, p.footprint[1] / 2, p.grid[1] * mesh.subdivisions + 1)
  zs = np.linspace(0, p.thickness, mesh.layers + 1)
  dx, dy = p.element_size
  cx, cy = p.element_centres()[9]  # an off-centre element
  patch = (cx - dx / 2, cx + dx / 2, cy - dy / 2, cy + dy / 2)
  # the same patch moved by one cell of the mesh, -x, +x, -y, +y
  sx, sy = dx / mesh.subdivisions, dy / mesh.subdivisions
  moved = [(patch[0] + a, patch[1] + a, patch[2] + b, patch[3] + b)
           for a, b in ((-sx, 0), (sx, 0), (0, -sy), (0, sy))]
  loads = np.column_stack([layer.patch_loads(xs, ys, len(zs), [patch]),
                           layer.patch_couples(xs, ys, len(zs), [patch]),
                           layer.patch_loads(xs, ys, len(zs), moved)[:, 2::3]])
  return layer.solve_block(xs, ys, zs, p.poisson_ratio, loads), (cx, cy), (sx, sy)


def _base_plane(sol):
  """Points on the plane through the centres of the elements adjoining the PCB, their areas
  and the compressive stress there for every load case."""
  c = 0.5 * (sol.zs[-1] + sol.zs[-2])
  xc = 0.5 * (sol.xs[1:] + sol.xs[:-1])
  yc = 0.5 * (sol.ys[1:] + sol.ys[:-1])
  gx, gy = np.meshgrid(xc, yc, indexing="ij")
  pts = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, c)], axis=1)
  area = np.outer(np.diff(sol.xs), np.diff(sol.ys)).ravel()
  return pts, area, -sol.stress_zz(pts), c


def test_base_plane_equilibrium(real_layer):
  sol, (x0, y0), _ = real_layer
  pts, area, p, c = _base_plane(sol)  # columns: unit Fx, Fy, Fz on the patch, ...
  # force: the normal stresses carry the applied normal force, and nothing of the shear
  assert np.sum(p[:, 2] * area) == pytest.approx(1.0, rel=0.02)
  assert abs(np.sum(p[:, 0] * area)) < 0.02
  # first moment: x0 * Fz + c * Fx (and y likewise)
  assert np.sum(p[:, 2] * pts[:, 0] * area) == pytest.approx(x0, rel=0.02)
  assert np.sum(p[:, 0] * pts[:, 0] * area) == pytest.approx(c, rel=0.02)
  assert np.sum(p[:, 1] * pts[:, 1] * area) == pytest.approx(c, rel=0.02)


def test_couple_is_a_normal_load_moved_sideways(real_layer):
  """The unit couple's die stresses match the derivative of a uniform normal patch load's
  stresses with respect to moving the patch (central difference over one mesh cell)."""
  sol, _, (sx, sy) = real_layer
  p = -sol.stress_zz(FootpadParams().die_positions())
  moved_x = (p[:, 6] - p[:, 5]) / (2 * sx)
  moved_y = (p[:, 8] - p[:, 7]) / (2 * sy)
  # Within 15 % over the six dies: the linear traction and the moved uniform patch differ at
  # second order, and the difference quotient carries the mesh's pressure noise (measured
  # 5 % along x, 13 % along y for this element, 1-2 mm from a die column).
  for couple, moved in ((p[:, 3], moved_x), (p[:, 4], moved_y)):
    assert np.linalg.norm(couple - moved) < 0.15 * np.linalg.norm(moved)
    assert np.sign(couple[np.argmax(np.abs(moved))]) == np.sign(moved[np.argmax(np.abs(moved))])


def test_deformed_pad_statics(real_layer):
  """Forces at the displaced contact point plus the p_delta couple balance the PCB's moment as
  the statics of the deformed pad says: Fz at x0 + ux, Fx on a lever shortened by qz."""
  sol, (x0, y0), _ = real_layer
  pts, area, p, c = _base_plane(sol)
  f = np.array([30.0, -20.0, 150.0])  # N on the rubber, +z compressing
  d = np.array([0.0021, -0.0013, 0.0012])  # m: sideways deflection, compression
  m = footpad.element_couples(f, d)
  stress = p[:, :3] @ f + p[:, 3:5] @ m
  assert np.sum(stress * pts[:, 0] * area) == pytest.approx(
      f[2] * (x0 + d[0]) + f[0] * (c - d[2]), rel=0.02)
  assert np.sum(stress * pts[:, 1] * area) == pytest.approx(
      f[2] * (y0 + d[1]) + f[1] * (c - d[2]), rel=0.02)
  # a couple carries no net force
  assert abs(np.sum(p[:, 3] * area)) < 1e-6 / np.max(np.abs(pts[:, 0]))


def test_halfspace_couple_is_a_moved_boussinesq_load():
  p = FootpadParams()
  couple = layer.halfspace_kernel(p)[:, :, 3]
  step = 1e-5
  moved = [dataclasses.replace(p, die_x=tuple(x - s for x in p.die_x)) for s in (step, -step)]
  # moving the dies by -s is moving every load by +s
  a, b = (layer.halfspace_kernel(q)[:, :, 2] for q in moved)
  fd = (a - b) / (2 * step)
  assert np.max(np.abs(couple - fd)) < 1e-5 * np.max(np.abs(fd))  # O(step^2) of the quotient


def test_kernels_agree_in_sign_and_order_for_normal_load():
  p = FootpadParams()
  g = layer.die_kernel(p, layer.Kernel.BONDED_LAYER)
  h = layer.die_kernel(p, layer.Kernel.HALFSPACE)
  assert g.shape == h.shape == (6, p.num_elements, 3)
  uniform_g = g[:, :, 2].sum(axis=1) / p.num_elements
  uniform_h = h[:, :, 2].sum(axis=1) / p.num_elements
  mean_stress = 1 / (p.footprint[0] * p.footprint[1])
  assert np.all((uniform_g > 0.7 * mean_stress) & (uniform_g < 1.1 * mean_stress))
  assert np.all((uniform_h > 0.7 * mean_stress) & (uniform_h < 1.1 * mean_stress))


def test_middle_row_blind_to_y_shear():
  """Under uniform Y shear the middle row (y = 0) sees almost nothing; under X shear it does."""
  p = FootpadParams()
  g = layer.die_kernel(p, layer.Kernel.BONDED_LAYER)
  middle = [i for i, (x, y, z) in enumerate(p.die_positions()) if y == 0]
  under_x = np.abs(g[middle, :, 0].sum(axis=1))
  under_y = np.abs(g[middle, :, 1].sum(axis=1))
  assert np.all(under_y < 0.1 * under_x)


def _pressed_stiffness(width, thickness, nu, cells, layers, axis=2):
  """Reaction of a square bonded block per unit displacement of its stuck face, E = 1."""
  xs = np.linspace(-width / 2, width / 2, cells + 1)
  zs = np.linspace(0, thickness, layers + 1)
  n = len(xs) ** 2
  move = np.zeros(3)
  move[axis] = 1.0
  sol = layer.solve_block(xs, xs, zs, nu, np.zeros((3 * n * len(zs), 0)), pressed=(tuple(move),))
  return (sol.stiffness @ sol.u[:, -1])[axis:3 * n:3].sum()


def test_pressed_block_without_poisson_coupling_is_EA_over_h():
  # nu = 0: uniaxial stress, exactly representable by the elements
  assert _pressed_stiffness(0.03, 0.01, 0.0, 6, 3) == pytest.approx(0.03**2 / 0.01, rel=1e-9)


def test_wide_pressed_block_tends_to_uniaxial_strain():
  # a thin bonded layer cannot bulge: constrained modulus E (1 - nu) / ((1 + nu)(1 - 2 nu))
  nu, width, h = 0.3, 0.1, 0.001
  m = (1 - nu) / ((1 + nu) * (1 - 2 * nu))
  assert _pressed_stiffness(width, h, nu, 50, 2) == pytest.approx(m * width**2 / h, rel=0.05)
  # and its shear stiffness tends to G A / h
  g = 1 / (2 * (1 + nu))
  assert _pressed_stiffness(width, h, nu, 50, 2, axis=0) == pytest.approx(g * width**2 / h,
                                                                          rel=0.05)
