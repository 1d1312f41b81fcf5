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
  return rotation_xp(np, np.asarray(angles, dtype=float))


def rotation_xp(xp, angles):
  """(..., 3, 3) `rotation(angles)` in the array module xp (numpy or jax.numpy), written out."""
  c, s = xp.cos(angles), xp.sin(angles)
  cx, cy, cz = c[..., 0], c[..., 1], c[..., 2]
  sx, sy, sz = s[..., 0], s[..., 1], s[..., 2]
  rows = [[cy * cz, -cy * sz, sy],
          [cx * sz + sx * sy * cz, cx * cz - sx * sy * sz, -sx * cy],
          [sx * sz - cx * sy * cz, sx * cz + cx * sy * sz, cx * cy]]
  if xp is np:  # filled in place: stacking nine arrays costs more than computing them
    out = np.empty(angles.shape[:-1] + (3, 3))
    for i, row in enumerate(rows):
      for j, v in enumerate(row):
        out[..., i, j] = v
    return out
  return xp.stack([xp.stack(row, axis=-1) for row in rows], axis=-2)


def plane_heights(xp, slopes, sensors, gap, rot, trans, centre):
  """(..., 8) heights above the sensors of the facet planes turned by `rot` about `centre`
  and moved by `trans`.

  The closed form, written so that it runs on numpy and, differentiable in every argument,
  on jax.numpy: a facet through p0 = sensor + (0, 0, gap) with normal n0 = (-s_x, -s_y, 1)
  meets the sensor's vertical at h = [n0 . (p0 - c) + (R n0) . (c + t - sensor)] / (R n0)_z,
  since (R n0) . R (p0 - c) = n0 . (p0 - c); every term is a small matrix product over the
  frames.

  Args:
    xp: the array module.
    slopes: (8, 2) facet slopes.  sensors: (8, 3) sensor apertures, m.  gap: rest height, m.
    rot: (..., 3, 3) rotations.  trans: (..., 3) displacements, m.  centre: (3,), m.
  """
  n0 = xp.stack([-slopes[:, 0], -slopes[:, 1], xp.ones_like(slopes[:, 0])], axis=1)  # (8, 3)
  const = xp.sum(n0 * (sensors + xp.stack([0.0 * gap, 0.0 * gap, gap]) - centre), axis=1)
  u = xp.einsum("...ij,...i->...j", rot, centre + trans)  # R^T (c + t)
  # (R n0) . sensor = sum_ij R_ij n0_j sensor_i: one product with a (9, 8) matrix
  m = (sensors[:, :, None] * n0[:, None, :]).reshape(8, 9).T
  flat = rot.reshape(rot.shape[:-2] + (9,))
  return (const + u @ n0.T - flat @ m) / (rot[..., 2, :] @ n0.T)


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
  rot = np.asarray(rot, float)
  trans = np.asarray(trans, float)
  c = np.array([0.0, 0.0, params.gap]) if centre is None else np.asarray(centre, float)
  sens = params.sensor_positions()
  h = plane_heights(np, params.slopes(), sens, params.gap, rot, trans, c)
  if not finite_facets:
    return h
  # where the line of sight meets the plane, back in the shell frame: R^T (hit - c - t) + c
  hit = sens + h[..., None] * np.array([0.0, 0.0, 1.0])
  local = np.einsum("...ji,...kj->...ki", rot, hit - c - trans[..., None, :]) + c
  off = np.abs(local[..., :2] - sens[:, :2])
  return np.where(np.all(off <= params.reflector_size / 2, axis=-1), h, np.nan)


def pose_heights(params: ShellParams, pose: np.ndarray, centre: np.ndarray | None = None,
                 finite_facets: bool = False) -> np.ndarray:
  """(..., 8) heights for poses (..., 6) = (x, y, z, then the `rotation` angles about x,
  turned y, turned z) about `centre` (default the centre of the reflector plane); see
  `heights`."""
  pose = np.asarray(pose, float)
  return heights(params, rotation_xp(np, pose[..., 3:]), pose[..., :3], centre, finite_facets)


def height_jacobian(params: ShellParams, step: float = 1e-7,
                    centre: np.ndarray | None = None) -> np.ndarray:
  """(8, 6) d heights / d pose at rest, by central differences of the closed form, the pose's
  rotations about `centre` (default the centre of the reflector plane)."""
  cols = []
  for j in range(6):
    d = np.zeros(6)
    d[j] = step
    cols.append((pose_heights(params, d, centre) - pose_heights(params, -d, centre))
                / (2 * step))
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
