"""Stress at the dies from tractions on the pad's contact face.

Two kernels map element forces f (num_elements, 3), in N, applied by the plate to the rubber's
contact face, to the compressive normal stress p = -sigma_zz (Pa) at each die:

* `bonded_layer_kernel`: a linear-elastic finite-element solution of the rubber block bonded
  to the rigid PCB (displacements fixed on the PCB face, other faces free), one solve per unit
  traction on each element's patch. A bonded layer turns the overturning moment of shear
  (shear x height) into a normal-stress difference across the board: the column difference by
  which a 2x3 array senses shear. A half-space kernel misses it: there shear reaches the dies
  only through Cerruti terms (~40 Pa per newton of uniform shear at each die, against 400-670
  Pa per newton from a single nearby element), and in an end-to-end prototype a linear fit
  then read shear at R2 ~35 % against the paper's 72-81 % (measured; `footpad_kernels`
  compares the two kernels on the current pad).
* `halfspace_kernel`: Boussinesq (normal) + Cerruti (tangential) point-load stresses integrated
  over each patch: the thick-layer limit of the former, kept as a selectable kernel.

Frame: z is the distance above the contact face (0) towards the PCB (thickness), as in the
carriage frame of `models.footpad`. A kernel is a (num_dies, num_elements, 3) array; stresses
do not depend on Young's modulus for a traction-loaded layer, only on Poisson's ratio.
"""

from __future__ import annotations

import dataclasses
import enum

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from models.footpad import FootpadParams
from sim import cache


class Kernel(enum.Enum):
  BONDED_LAYER = "bonded_layer"
  HALFSPACE = "halfspace"


# ---------------------------------------------------------------------------------------------
# Hexahedral finite elements on a rectilinear grid.

_CORNERS = np.array([[i, j, k] for k in (0, 1) for j in (0, 1) for i in (0, 1)], dtype=float)
_SIGNS = 2.0 * _CORNERS - 1.0  # (8, 3) reference-corner signs
_GAUSS2 = np.array([-1.0, 1.0]) / np.sqrt(3.0)


def _dshape(xi: np.ndarray, size: np.ndarray) -> np.ndarray:
  """Shape-function gradients of box elements.

  Args:
    xi: (3,) reference coordinates in [-1, 1].
    size: (E, 3) element edge lengths, m.
  Returns:
    (E, 8, 3) dN_a/dx_i.
  """
  s = _SIGNS
  f = 1.0 + s * xi  # (8, 3)
  dref = np.stack([s[:, 0] * f[:, 1] * f[:, 2], f[:, 0] * s[:, 1] * f[:, 2],
                   f[:, 0] * f[:, 1] * s[:, 2]], axis=1) / 8.0
  return dref[None, :, :] * (2.0 / size)[:, None, :]


def _strain_matrix(dn: np.ndarray) -> np.ndarray:
  """(E, 6, 24) engineering-strain matrix [xx, yy, zz, yz, xz, xy] from (E, 8, 3) gradients."""
  e = dn.shape[0]
  b = np.zeros((e, 6, 24))
  for a in range(8):
    dx, dy, dz = dn[:, a, 0], dn[:, a, 1], dn[:, a, 2]
    c = 3 * a
    b[:, 0, c] = dx
    b[:, 1, c + 1] = dy
    b[:, 2, c + 2] = dz
    b[:, 3, c + 1] = dz
    b[:, 3, c + 2] = dy
    b[:, 4, c] = dz
    b[:, 4, c + 2] = dx
    b[:, 5, c] = dy
    b[:, 5, c + 1] = dx
  return b


def _lame(nu: float) -> tuple[float, float]:
  """Lame constants for E = 1 (stresses of a traction-loaded body do not depend on E)."""
  return nu / ((1 + nu) * (1 - 2 * nu)), 1.0 / (2 * (1 + nu))


_M = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
_DMU = np.diag([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])


@dataclasses.dataclass(frozen=True)
class LayerSolution:
  """Displacements of a block for a set of load cases.

  Attributes:
    xs, ys, zs: node coordinates along each axis, m (z = 0 is the loaded face).
    nu: Poisson's ratio.
    u: (num_nodes * 3, num_cases) nodal displacements for E = 1 Pa.
  """
  xs: np.ndarray
  ys: np.ndarray
  zs: np.ndarray
  nu: float
  u: np.ndarray
  stiffness: scipy.sparse.csc_matrix

  def _element_szz(self, point, idx, lam, mu) -> np.ndarray:
    nx, ny = len(self.xs), len(self.ys)
    lo = np.array([self.xs[idx[0]], self.ys[idx[1]], self.zs[idx[2]]])
    hi = np.array([self.xs[idx[0] + 1], self.ys[idx[1] + 1], self.zs[idx[2] + 1]])
    size = (hi - lo)[None, :]
    xi = 2.0 * (np.asarray(point) - lo) / size[0] - 1.0
    corner_nodes = [(idx[0] + i) + nx * ((idx[1] + j) + ny * (idx[2] + k))
                    for i, j, k in _CORNERS.astype(int)]
    dofs = (3 * np.array(corner_nodes)[:, None] + np.arange(3)).ravel()
    ue = self.u[dofs]
    eps = _strain_matrix(_dshape(xi, size))[0] @ ue
    vol = _M @ _strain_matrix(_dshape(np.zeros(3), size))[0] @ ue
    return mu * (_DMU @ eps)[2] + lam * vol

  def stress_zz(self, points: np.ndarray) -> np.ndarray:
    """sigma_zz (Pa, tension positive) at (P, 3) points for every load case: (P, num_cases).

    Selective reduced integration is used consistently: the shear part at the point, the
    volumetric part at the element centre.
    """
    lam, mu = _lame(self.nu)
    out = np.empty((len(points), self.u.shape[1]))
    for p, point in enumerate(points):
      # A point on a grid plane takes the mean of the elements on either side.
      cands = []
      for c, v in zip((self.xs, self.ys, self.zs), point):
        i = int(np.clip(np.searchsorted(c, v, side="right") - 1, 0, len(c) - 2))
        near = [j for j in (i - 1, i, i + 1) if 0 <= j <= len(c) - 2
                and c[j] - 1e-12 <= v <= c[j + 1] + 1e-12]
        cands.append(near)
      vals = [self._element_szz(point, (i, j, k), lam, mu)
              for i in cands[0] for j in cands[1] for k in cands[2]]
      out[p] = np.mean(vals, axis=0)
    return out


def solve_block(xs: np.ndarray, ys: np.ndarray, zs: np.ndarray, nu: float,
                loads: np.ndarray, symmetric_xy: bool = False,
                pressed: tuple[tuple[float, float, float], ...] = ()) -> LayerSolution:
  """Solves a linear-elastic block fixed on its top face (z = zs[-1]).

  Args:
    xs, ys, zs: increasing node coordinates, m.
    nu: Poisson's ratio, in [0, 0.5).
    loads: (num_nodes * 3, num_cases) nodal forces, N; node index ix + nx*(iy + ny*iz).
    symmetric_xy: the block is the quarter x >= 0, y >= 0 of a body symmetric about the
      planes x = 0 and y = 0 (u_x = 0 on x = 0, u_y = 0 on y = 0); valid for normal loads.
    pressed: rigid-plate displacements of the face z = 0, m (e.g. (0, 0, 1): pressed 1 m into
      the block), the plate stuck to the face; one extra load case each, after `loads`. With
      any, the face is held in every load case.
  Returns:
    The displacements for E = 1 Pa; the reactions of the pressed face are `k @ u`.
  """
  xs, ys, zs = (np.asarray(c, dtype=float) for c in (xs, ys, zs))
  nx, ny, nz = len(xs), len(ys), len(zs)
  lam, mu = _lame(nu)
  ex, ey, ez = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), np.arange(nz - 1),
                           indexing="ij")
  ex, ey, ez = ex.ravel(), ey.ravel(), ez.ravel()
  size = np.stack([np.diff(xs)[ex], np.diff(ys)[ey], np.diff(zs)[ez]], axis=1)
  vol = np.prod(size, axis=1)
  ke = np.zeros((len(ex), 24, 24))
  for gx in _GAUSS2:
    for gy in _GAUSS2:
      for gz in _GAUSS2:
        b = _strain_matrix(_dshape(np.array([gx, gy, gz]), size))
        ke += mu * np.einsum("eia,ij,ejb->eab", b, _DMU, b) * (vol / 8)[:, None, None]
  bc = _M @ _strain_matrix(_dshape(np.zeros(3), size))  # (E, 24)
  ke += lam * np.einsum("ea,eb->eab", bc, bc) * vol[:, None, None]

  nodes = np.stack([(ex + i) + nx * ((ey + j) + ny * (ez + k))
                    for i, j, k in _CORNERS.astype(int)], axis=1)
  dofs = (3 * nodes[:, :, None] + np.arange(3)).reshape(len(ex), 24)
  rows = np.repeat(dofs, 24, axis=1).ravel()
  cols = np.tile(dofs, (1, 24)).ravel()
  ndof = 3 * nx * ny * nz
  k = scipy.sparse.csc_matrix((ke.ravel(), (rows, cols)), shape=(ndof, ndof))
  fixed = np.zeros(ndof, dtype=bool)
  fixed[3 * nx * ny * (nz - 1):] = True
  if symmetric_xy:
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")[:2]
    node = np.arange(nx * ny * nz).reshape(nz, ny, nx).transpose(2, 1, 0)
    fixed[3 * node[ix == 0]] = True
    fixed[3 * node[iy == 0] + 1] = True
  loads = np.asarray(loads, dtype=float)
  u = np.zeros((ndof, loads.shape[1] + len(pressed)))
  if pressed:
    face = np.arange(3 * nx * ny)
    fixed[face] = True
    for j, move in enumerate(pressed, start=loads.shape[1]):
      for c in range(3):
        u[face[c::3], j] = move[c]
    loads = np.column_stack([loads, -(k @ u[:, loads.shape[1]:])])
  free = np.flatnonzero(~fixed)
  kff = k[free][:, free].tocsc()
  lu = scipy.sparse.linalg.splu(kff, permc_spec="COLAMD")
  u[free] = lu.solve(loads[free])
  return LayerSolution(xs, ys, zs, nu, u, k)


def _patch_cells(xs: np.ndarray, ys: np.ndarray, patch, i: int):
  """Index ranges of the face cells covering one patch; its edges must be grid lines."""
  x0, x1, y0, y1 = patch
  ix0, ix1 = (int(np.argmin(np.abs(xs - v))) for v in (x0, x1))
  iy0, iy1 = (int(np.argmin(np.abs(ys - v))) for v in (y0, y1))
  if not (np.isclose(xs[ix0], x0) and np.isclose(xs[ix1], x1) and np.isclose(ys[iy0], y0)
          and np.isclose(ys[iy1], y1)):
    raise ValueError(f"patch {i} edges do not fall on the finite-element grid lines")
  return range(ix0, ix1), range(iy0, iy1)


def patch_loads(xs: np.ndarray, ys: np.ndarray, nz: int,
                patches: list[tuple[float, float, float, float]]) -> np.ndarray:
  """Consistent nodal forces of unit-total tractions on rectangles of the face z = 0.

  Args:
    xs, ys: node coordinates; every patch edge must fall on a grid line.
    nz: number of node planes along z.
    patches: (x0, x1, y0, y1) rectangles, m.
  Returns:
    (num_nodes * 3, 3 * len(patches)) forces: for patch i, columns 3i..3i+2 carry a unit force
    along x, y, z (z pointing into the rubber).
  """
  nx, ny = len(xs), len(ys)
  out = np.zeros((3 * nx * ny * nz, 3 * len(patches)))
  for i, patch in enumerate(patches):
    x0, x1, y0, y1 = patch
    area = (x1 - x0) * (y1 - y0)
    cells_x, cells_y = _patch_cells(xs, ys, patch, i)
    for jx in cells_x:
      for jy in cells_y:
        share = (xs[jx + 1] - xs[jx]) * (ys[jy + 1] - ys[jy]) / area / 4.0
        for cx, cy in ((0, 0), (1, 0), (0, 1), (1, 1)):
          node = (jx + cx) + nx * (jy + cy)
          for c in range(3):
            out[3 * node + c, 3 * i + c] += share
  return out


def patch_couples(xs: np.ndarray, ys: np.ndarray, nz: int,
                  patches: list[tuple[float, float, float, float]]) -> np.ndarray:
  """Consistent nodal forces of unit couples on rectangles of the face z = 0.

  A couple is a normal traction (into the rubber) varying linearly across the patch, with no
  net force and a unit first moment about the patch centre: t = (x - xc) / I_x for the couple
  along x, and likewise along y. To first order it is what a patch's normal force f adds when
  the patch moves by a small u (couple f * u, N m). The exact first-order change, a line load
  on one edge less one on the other, is not used: concentrated loads excite the mesh-scale
  pressure modes of the nearly incompressible elements (its die stresses were off by up to
  2x from moving the patch by one cell), while this smooth traction agrees with it.

  Returns:
    (num_nodes * 3, 2 * len(patches)) forces: for patch i, columns 2i, 2i+1 carry the unit
    couple along x and along y (N per N m).
  """
  nx, ny = len(xs), len(ys)
  out = np.zeros((3 * nx * ny * nz, 2 * len(patches)))
  for i, patch in enumerate(patches):
    x0, x1, y0, y1 = patch
    centre = np.array([x0 + x1, y0 + y1]) / 2
    inertia = np.array([(x1 - x0) ** 3 * (y1 - y0), (x1 - x0) * (y1 - y0) ** 3]) / 12
    cells_x, cells_y = _patch_cells(xs, ys, patch, i)
    for jx in cells_x:
      for jy in cells_y:
        lo = np.array([xs[jx], ys[jy]])
        size = np.array([xs[jx + 1] - xs[jx], ys[jy + 1] - ys[jy]])
        # 2 x 2 Gauss points: exact for a bilinear shape function times a linear traction
        for gx in _GAUSS2:
          for gy in _GAUSS2:
            r = (np.array([gx, gy]) + 1) / 2
            t = (lo + r * size - centre) / inertia * np.prod(size) / 4
            for cx, cy in ((0, 0), (1, 0), (0, 1), (1, 1)):
              shape = (r[0] if cx else 1 - r[0]) * (r[1] if cy else 1 - r[1])
              node = (jx + cx) + nx * (jy + cy)
              out[3 * node + 2, 2 * i:2 * i + 2] += shape * t
  return out


# ---------------------------------------------------------------------------------------------
# Kernels for a footpad.

@dataclasses.dataclass(frozen=True)
class LayerMesh:
  """Finite-element resolution of the bonded layer.

  Attributes:
    subdivisions: elements across each bristle patch in X and Y (patch edges are grid lines).
    layers: elements through the rubber thickness.
  """
  subdivisions: int = 4
  layers: int = 8


def _patches(params: FootpadParams) -> list[tuple[float, float, float, float]]:
  dx, dy = params.element_size
  return [(cx - dx / 2, cx + dx / 2, cy - dy / 2, cy + dy / 2)
          for cx, cy in params.element_centres()]


def _grid(params: FootpadParams, mesh: LayerMesh):
  """Node coordinates of the block under the pad: patch edges fall on grid lines."""
  xs = np.linspace(-params.footprint[0] / 2, params.footprint[0] / 2,
                   params.grid[0] * mesh.subdivisions + 1)
  ys = np.linspace(-params.footprint[1] / 2, params.footprint[1] / 2,
                   params.grid[1] * mesh.subdivisions + 1)
  return xs, ys, np.linspace(0.0, params.thickness, mesh.layers + 1)


def bonded_layer_kernel(params: FootpadParams, mesh: LayerMesh = LayerMesh()) -> np.ndarray:
  """(num_dies, num_elements, 5) die pressure: Pa per N of element force along x, y, z, then
  Pa per N m of element couple along x, y (`patch_couples`), from one factorisation."""
  xs, ys, zs = _grid(params, mesh)
  patches = _patches(params)
  loads = np.column_stack([patch_loads(xs, ys, len(zs), patches),
                           patch_couples(xs, ys, len(zs), patches)])
  sol = solve_block(xs, ys, zs, params.poisson_ratio, loads)
  p = -sol.stress_zz(params.die_positions())  # (dies, 5 * elements)
  e = params.num_elements
  return np.concatenate([p[:, :3 * e].reshape(len(p), e, 3),
                         p[:, 3 * e:].reshape(len(p), e, 2)], axis=2)


def boussinesq_cerruti(points: np.ndarray, load_xy: np.ndarray,
                       moved: bool = False) -> np.ndarray:
  """Compressive sigma_zz of an elastic half-space under unit surface point loads.

  Args:
    points: (P, 3) points (x, y, depth), m.
    load_xy: (L, 2) load points on the surface, m.
    moved: also return the rate of change of the normal load's stress as the load point
      moves along x and y (Pa per N m).
  Returns:
    (P, L, 3) pressure, Pa per N, for unit loads along x, y (Cerruti) and into the body
    (Boussinesq): p = 3 z^2 (F_z z + F_x dx + F_y dy) / (2 pi R^5), dx = point - load;
    with `moved`, (P, L, 5), the last two being d/d(load x, y) of the Boussinesq term,
    15 z^3 (dx, dy) / (2 pi R^7).
  """
  d = points[:, None, :2] - load_xy[None, :, :]
  z = points[:, None, 2]
  r2 = np.sum(d**2, axis=-1) + z**2
  c = 3.0 * z**2 / (2.0 * np.pi * r2**2.5)
  out = [c * d[..., 0], c * d[..., 1], c * z]
  if moved:
    out += [5.0 * c * z * d[..., 0] / r2, 5.0 * c * z * d[..., 1] / r2]
  return np.stack(out, axis=-1)


def halfspace_kernel(params: FootpadParams, quadrature: int = 6) -> np.ndarray:
  """(num_dies, num_elements, 5) half-space die pressure, laid out as `bonded_layer_kernel`'s,
  each patch load spread uniformly over a quadrature x quadrature midpoint rule."""
  dx, dy = params.element_size
  offs = (np.arange(quadrature) + 0.5) / quadrature - 0.5
  ox, oy = np.meshgrid(offs * dx, offs * dy, indexing="ij")
  sub = np.stack([ox.ravel(), oy.ravel()], axis=1)
  centres = params.element_centres()
  pts = (centres[:, None, :] + sub[None]).reshape(-1, 2)
  k = boussinesq_cerruti(params.die_positions(), pts, moved=True)
  return k.reshape(len(k), params.num_elements, len(sub), 5).mean(axis=2)


def plate_stiffness(params: FootpadParams, mesh: LayerMesh = LayerMesh()) -> np.ndarray:
  """(num_elements, 3) spring rates (kx, ky, kz) of the flat pad's elements, N/m.

  The bonded block's face is moved by a rigid plate stuck to it, along x, y and z in turn;
  each element takes its tributary share of the face's nodal reactions along that axis.
  """
  xs, ys, zs = _grid(params, mesh)
  n = len(xs) * len(ys)
  # patch_loads' z columns hold each face node's area share in each patch
  share = patch_loads(xs, ys, len(zs), _patches(params))[2:3 * n:3, 2::3]
  share = share / share.sum(axis=1, keepdims=True)
  sol = solve_block(xs, ys, zs, params.poisson_ratio, np.zeros((3 * n * len(zs), 0)),
                    pressed=tuple(tuple(row) for row in np.eye(3)))
  reaction = sol.stiffness @ sol.u  # (ndof, 3): one column per direction moved
  out = np.stack([share.T @ reaction[c:3 * n:3, c] for c in range(3)], axis=1)
  return params.youngs_modulus * out


def _layer_key(params: FootpadParams, mesh: LayerMesh, dies: bool = True) -> dict:
  """What a finite-element result depends on (results are per unit E, so not E)."""
  key = {"footprint": params.footprint, "grid": params.grid, "thickness": params.thickness,
         "nu": params.poisson_ratio, "mesh": dataclasses.asdict(mesh), "version": 2}
  if dies:
    key["dies"] = params.die_positions().round(9).tolist()
  return key


def _kernels(params: FootpadParams, kernel: Kernel, mesh: LayerMesh) -> np.ndarray:
  """Both kernels of one kind, (num_dies, num_elements, 5); finite-element ones cached."""
  if kernel is Kernel.HALFSPACE:
    return halfspace_kernel(params)
  return cache.cached_array("kernels", _layer_key(params, mesh),
                            lambda: bonded_layer_kernel(params, mesh))


def die_kernel(params: FootpadParams, kernel: Kernel = Kernel.BONDED_LAYER,
               mesh: LayerMesh = LayerMesh()) -> np.ndarray:
  """(num_dies, num_elements, 3) die pressure, Pa per N of element force along x, y, z."""
  return _kernels(params, kernel, mesh)[..., :3]


def couple_kernel(params: FootpadParams, kernel: Kernel = Kernel.BONDED_LAYER,
                  mesh: LayerMesh = LayerMesh()) -> np.ndarray:
  """(num_dies, num_elements, 2) die pressure, Pa per N m of element couple along x, y."""
  return _kernels(params, kernel, mesh)[..., 3:]


def element_stiffness(params: FootpadParams, mesh: LayerMesh = LayerMesh()) -> np.ndarray:
  """(num_elements, 3) element spring rates, N/m, that `params.stiffness_profile` asks for.

  "bonded_plate": `plate_stiffness` (cached), each element scaled by thickness / local
  thickness where a crown thins the rubber; "uniform": free rubber columns.
  """
  if params.stiffness_profile == "uniform":
    return params.element_stiffness()
  per_e = cache.cached_array("stiffness", _layer_key(params, mesh, dies=False),
                  lambda: plate_stiffness(params, mesh) / params.youngs_modulus)
  crown = params.thickness / (params.thickness - params.crown_sag())
  return params.youngs_modulus * per_e * crown[:, None]
