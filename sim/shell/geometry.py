"""Reflector heights above the shell's photointerrupters: closed form, rays, and the linear map.

Each reflector facet is a plane fixed to the shell: through (x_i, y_i, gap) at rest, rising
by the facet's slopes (`ShellParams.slopes`). A sensor reads the distance straight up (+z of
the chassis) from its aperture to that plane. `heights` intersects the planes in closed form
(the fast path, vectorised over frames); `ray_heights` casts MuJoCo rays at the model's
facet meshes, the reference it must agree with. `height_jacobian` is the simulated version of
the paper's Eqn 3, about the centre of the reflector plane as the paper writes it.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from models import shell as shell_model
from models.shell import ShellParams


def rotation(angles: np.ndarray) -> np.ndarray:
  """(..., 3, 3) rotation of the mount's hinge chain: about x, then the turned y, then z."""
  a = np.asarray(angles, dtype=float)
  c, s = np.cos(a), np.sin(a)
  one, zero = np.ones_like(a[..., 0]), np.zeros_like(a[..., 0])
  rx = np.stack([one, zero, zero, zero, c[..., 0], -s[..., 0], zero, s[..., 0], c[..., 0]],
                axis=-1).reshape(a.shape[:-1] + (3, 3))
  ry = np.stack([c[..., 1], zero, s[..., 1], zero, one, zero, -s[..., 1], zero, c[..., 1]],
                axis=-1).reshape(a.shape[:-1] + (3, 3))
  rz = np.stack([c[..., 2], -s[..., 2], zero, s[..., 2], c[..., 2], zero, zero, zero, one],
                axis=-1).reshape(a.shape[:-1] + (3, 3))
  return rx @ ry @ rz


def heights(params: ShellParams, rot: np.ndarray, trans: np.ndarray,
            centre: np.ndarray | None = None, finite_facets: bool = False) -> np.ndarray:
  """(..., 8) vertical distance from each sensor to its facet, m.

  Args:
    params: layout and slopes.
    rot: (..., 3, 3) shell orientation in the chassis frame (identity at rest).
    trans: (..., 3) shell displacement from rest, m.
    centre: point (chassis frame) the rotation is about; default the centre of the
      reflector plane, (0, 0, gap).
    finite_facets: NaN where the sensor's line of sight passes beside its facet (a square
      of side reflector_size in the shell frame), as a ray would; else the facet planes are
      unbounded.
  """
  c = np.array([0.0, 0.0, params.gap]) if centre is None else np.asarray(centre, float)
  sens = params.sensor_positions()
  p0 = sens + np.array([0.0, 0.0, params.gap])  # facet points above the sensors at rest
  slopes = params.slopes()
  n0 = np.column_stack([-slopes, np.ones(8)])  # facet normals (unnormalised), shell frame
  rot = np.asarray(rot, float)
  trans = np.asarray(trans, float)
  p = np.einsum("...ij,kj->...ki", rot, p0 - c) + c + trans[..., None, :]
  n = np.einsum("...ij,kj->...ki", rot, n0)
  # sensor + h e_z on the plane: n . (sensor + h e_z - p) = 0
  h = np.sum(n * (p - sens), axis=-1) / n[..., 2]
  if not finite_facets:
    return h
  hit = sens + h[..., None] * np.array([0.0, 0.0, 1.0])
  # back into the shell frame: R^T (hit - c - t) + c
  local = np.einsum("...ji,...kj->...ki", rot, hit - c - trans[..., None, :]) + c
  off = np.abs(local[..., :2] - sens[:, :2])
  return np.where(np.all(off <= params.reflector_size / 2, axis=-1), h, np.nan)


def pose_heights(params: ShellParams, pose: np.ndarray, centre: np.ndarray | None = None,
                 finite_facets: bool = False) -> np.ndarray:
  """(..., 8) heights for poses (..., 6) = (x, y, z, then the `rotation` angles about x,
  turned y, turned z) about `centre` (default the centre of the reflector plane); see
  `heights`."""
  pose = np.asarray(pose, float)
  return heights(params, rotation(pose[..., 3:]), pose[..., :3], centre, finite_facets)


def height_jacobian(params: ShellParams, step: float = 1e-7) -> np.ndarray:
  """(8, 6) d heights / d pose at rest, by central differences of the closed form."""
  cols = []
  for j in range(6):
    d = np.zeros(6)
    d[j] = step
    cols.append((pose_heights(params, d) - pose_heights(params, -d)) / (2 * step))
  return np.stack(cols, axis=1)


@dataclasses.dataclass(frozen=True)
class MapQuality:
  """How well the eight heights determine the six pose coordinates.

  Attributes:
    rank: numerical rank of the height map (6 when every direction is observed).
    condition: ratio of largest to smallest singular value, rotations scaled by
      `length_scale` (inf when rank-deficient).
    lost: names of pose directions (combinations, as unit vectors over x, y, z, theta_x,
      theta_y, theta_z) that no sensor sees; empty at rank 6.
  """
  rank: int
  condition: float
  lost: tuple[str, ...]


POSE_NAMES = ("x", "y", "z", "theta_x", "theta_y", "theta_z")


def map_quality(jacobian: np.ndarray, length_scale: float = 0.025,
                rtol: float = 1e-9) -> MapQuality:
  """Rank, condition number and lost directions of an (8, 6) height map."""
  # a rotation counts as the arc it sweeps at length_scale
  scaled = np.asarray(jacobian, float) / np.array([1, 1, 1, length_scale, length_scale,
                                                    length_scale])
  _, sv, vt = np.linalg.svd(scaled)
  rank = int(np.sum(sv > rtol * sv[0]))
  lost = []
  for v in vt[rank:]:
    v = v / np.max(np.abs(v))
    lost.append(" + ".join(f"{c:.2g} {n}" for c, n in zip(v, POSE_NAMES) if abs(c) > 1e-3))
  cond = float(sv[0] / sv[rank - 1]) if rank == 6 else float("inf")
  return MapQuality(rank, cond, tuple(lost))


def ray_heights(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
  """(8,) heights by `mj_ray` from each sensor site straight up, seeing reflector geoms only
  (geom group `models.shell.REFLECTOR_GROUP`); NaN where a ray misses."""
  group = np.zeros(6, np.uint8)
  group[shell_model.REFLECTOR_GROUP] = 1
  out = np.full(8, np.nan)
  geomid = np.zeros(1, np.int32)
  for i in range(8):
    site = data.site(f"P{i + 1}")
    up = site.xmat.reshape(3, 3)[:, 2].copy()
    dist = mujoco.mj_ray(model, data, site.xpos, up, group, 1, -1, geomid)
    if dist >= 0:
      out[i] = dist
  return out


def rays_at(model: mujoco.MjModel, data: mujoco.MjData, pose: np.ndarray) -> np.ndarray:
  """(8,) `ray_heights` with the mount joints at `pose` (6,) and every other joint at 0."""
  data.qpos[:] = 0
  data.qpos[shell_model.mount_qpos_index(model)] = pose
  mujoco.mj_kinematics(model, data)
  return ray_heights(model, data)


def ray_jacobian(params: ShellParams, step: float = 1e-6) -> np.ndarray:
  """(8, 6) d(ray heights)/d(pose about the reflector plane's centre) of the MuJoCo model."""
  model = shell_model.build_spec(params).compile()
  data = mujoco.MjData(model)

  def rays(q):
    return rays_at(model, data, q)
  jac = np.stack([(rays(step * e) - rays(-step * e)) / (2 * step) for e in np.eye(6)], axis=1)
  # a turn theta about the elastic centre, dz below the plane, moves the plane's centre by
  # (theta_y dz, -theta_x dz, 0)
  dz = params.gap - shell_model.elastic_centre(params)[2]
  to_plane = np.eye(6)
  to_plane[0, 4], to_plane[1, 3] = dz, -dz
  return jac @ np.linalg.inv(to_plane)
