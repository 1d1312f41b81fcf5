"""Pictures of the rigs, drawn offscreen (no display needed).

  python -m sim.render footpad [--out footpad.png] [--time T] [--path x_stroke] [--z 1.0]
  python -m sim.render shell [--out shell.png] [--time T]
  python -m sim.render footpad --video footpad.mp4     # needs: pip install -e '.[video]'

The footpad runs one CNC path of the paper at one depth (`trajectories.episode`) from rest to
time T (default: halfway along), its contact points and forces on the plate drawn; the shell
settles on its springs over the reflectors for T seconds, each photointerrupter's beam drawn
in red from its sensor to the facet it reads. MuJoCo renders through EGL (GPU or
Mesa) or OSMesa: set MUJOCO_GL=egl or MUJOCO_GL=osmesa; on Debian/Ubuntu the libraries are the
packages libegl1 (with libgl1-mesa-dri) or libosmesa6. `render` picks EGL, then OSMesa, when
MUJOCO_GL is not set, provided it runs before MuJoCo is first imported (the command does; in
your own script call `sim.render.choose_backend()` first, or set MUJOCO_GL).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pathlib
import sys
from typing import Iterator, Optional

import numpy as np

from util import cli, errors, files

RIGS = ("footpad", "shell")
GL_BACKENDS = ("egl", "osmesa", "glfw", "glx")  # MuJoCo's, on Linux
FPS = 30
VIDEO_SUFFIXES = (".mp4", ".mkv", ".avi", ".mov")  # what imageio's ffmpeg writer takes


@dataclasses.dataclass(frozen=True)
class View:
  """A free camera: the point it looks at (m), its distance (m) and angles (deg)."""
  lookat: tuple[float, float, float]
  distance: float
  azimuth: float
  elevation: float


def choose_backend() -> Optional[str]:
  """Sets MUJOCO_GL to an offscreen backend (EGL if its library is found, else OSMesa) unless
  it is set; returns the backend (None: neither found, and `frames` says what to install).
  MuJoCo reads MUJOCO_GL when first imported, so call this before that: the command and
  the functions here call it before they import MuJoCo (this module imports it only inside
  them), and importing this module changes nothing."""
  chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
  if chosen:
    if chosen not in GL_BACKENDS:
      raise errors.SettingError(f"MUJOCO_GL={os.environ['MUJOCO_GL']!r} is not a GL backend "
                                f"MuJoCo renders offscreen with: allowed {', '.join(GL_BACKENDS)} "
                                f"(or unset it to let the command choose)")
    return chosen
  import ctypes.util
  for backend, library in (("egl", "EGL"), ("osmesa", "OSMesa")):
    if ctypes.util.find_library(library):
      os.environ["MUJOCO_GL"] = backend
      return backend
  return None


def footpad_run(path: str = "x_stroke", z: float = 1e-3):
  """(model, a stepper, episode seconds, view) of the footpad on one of the paper's paths at
  depth z (m), with the protocol's default scene."""
  import mujoco
  from sim.footpad import protocol, scene as scene_lib, trajectories
  scene = dataclasses.replace(protocol.base(quick=True, seed=0), paths=(path,), z_levels=(z,))
  scene.validate()
  model = scene_lib.compile_model(scene)
  # MuJoCo draws a force f as f * map.force / meanmass long: the elements' ~2 N, 4 mm
  model.vis.map.force = 2e-3 * float(model.stat.meanmass)
  ep = trajectories.episode(path, z, scene.feed, scene.params.timestep, repeats=1)
  data = mujoco.MjData(model)
  from models import footpad as model_lib
  data.qpos[model_lib.cnc_qpos_index(model)] = ep.target[0]

  def step_to(t: float):
    n = min(int(round(t / model.opt.timestep)), len(ep.target) - 1)
    while data.time < n * model.opt.timestep - 1e-12:
      k = min(int(round(data.time / model.opt.timestep)), len(ep.target) - 1)
      data.ctrl[:] = ep.target[k]
      mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return data
  return model, step_to, len(ep.target) * model.opt.timestep, View((0, 0, 0.0), 0.13, 135, -22)


def _beams(model, data, scene) -> None:
  """Each photointerrupter's beam, from its site up to the reflector facet its ray meets
  (`sim.shell.geometry.ray_heights`), drawn into the scene as a red line."""
  import mujoco
  from sim.shell import geometry
  heights = geometry.ray_heights(model, data)
  for i, h in enumerate(heights):
    if not np.isfinite(h) or scene.ngeom >= scene.maxgeom:
      continue
    site = data.site(f"P{i + 1}")
    start = site.xpos.copy()
    end = start + h * site.xmat.reshape(3, 3)[:, 2]
    g = scene.geoms[scene.ngeom]
    mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_LINE, np.zeros(3), np.zeros(3), np.zeros(9),
                        np.array([1.0, 0.1, 0.1, 1.0], np.float32))
    mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_LINE, 3.0, start, end)
    # no model object behind it: segmentation reads it as such
    g.objtype, g.objid, g.segid = mujoco.mjtObj.mjOBJ_UNKNOWN, -1, scene.ngeom
    scene.ngeom += 1


def shell_run():
  """(model, a stepper, seconds, view) of the shell at rest on its springs."""
  import mujoco
  from sim.shell import protocol, scene as shell_scene
  board = protocol.base(quick=True, seed=0)
  model = shell_scene.compile_checked(board.spec(), "shell render", board.params)
  data = mujoco.MjData(model)

  def step_to(t: float):
    while data.time < t - 1e-12:
      mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return data
  # close and nearly level, so the 2-4 mm gap between the sensors and the facets shows
  plate = model.geom("reflector_plate").pos
  return model, step_to, 0.5, View((float(plate[0]), float(plate[1]), float(plate[2]) - 0.002),
                                   0.08, 165, -4)


def rig_run(rig: str, path: str = "x_stroke", z: float = 1e-3):
  """`footpad_run(path, z)` or `shell_run()` by the rig's name."""
  if rig not in RIGS:
    raise errors.SettingError(f"rig {rig!r} is unknown: allowed {', '.join(RIGS)}")
  return footpad_run(path, z) if rig == "footpad" else shell_run()


def frames(rig: str, times: list[float], size: tuple[int, int] = (640, 480), *,
           path: str = "x_stroke", z: float = 1e-3, segmentation: bool = False,
           run=None) -> Iterator[tuple[float, np.ndarray, object]]:
  """(time, image, renderer scene) at each of `times` (s, increasing): RGB (H, W, 3) uint8,
  or with `segmentation` (H, W, 2) int32 of object id and type per pixel. `run` is a
  `rig_run` not yet stepped past times[0] (built here when None)."""
  choose_backend()
  import mujoco
  model, step_to, _, view = run or rig_run(rig, path, z)
  width, height = size
  if not (16 <= width <= model.vis.global_.offwidth and 16 <= height <= model.vis.global_.offheight):
    raise errors.SettingError(f"image size {width}x{height} is out of range: allowed 16 to "
                              f"{model.vis.global_.offwidth}x{model.vis.global_.offheight} px")
  try:
    renderer = mujoco.Renderer(model, height, width)
  except Exception as err:  # no GL library: say which package gives one
    raise errors.SimulationError(
        f"render: MuJoCo could not open an offscreen context with MUJOCO_GL="
        f"{os.environ.get('MUJOCO_GL')} ({err}); set MUJOCO_GL=egl (or osmesa) before Python "
        f"starts, or call sim.render.choose_backend() before importing mujoco, and install libegl1 and "
        f"libgl1-mesa-dri (EGL) or libosmesa6 (OSMesa)") from None
  cam = mujoco.MjvCamera()
  cam.type = mujoco.mjtCamera.mjCAMERA_FREE
  cam.lookat[:], cam.distance, cam.azimuth, cam.elevation = (
      view.lookat, view.distance, view.azimuth, view.elevation)
  opt = mujoco.MjvOption()
  opt.flags[mujoco.mjtVisFlag.mjVIS_CONTACTPOINT] = True
  opt.flags[mujoco.mjtVisFlag.mjVIS_CONTACTFORCE] = True
  if segmentation:
    renderer.enable_segmentation_rendering()
  try:
    for t in times:
      data = step_to(t)
      renderer.update_scene(data, cam, opt)
      if rig == "shell":
        _beams(model, data, renderer.scene)
      yield t, renderer.render().copy(), renderer.scene
  finally:
    renderer.close()


def project(scene, point: np.ndarray, size: tuple[int, int], fovy: float) -> tuple[int, int]:
  """(row, column) of the pixel where the world point (m) lands in an image of `size` (W, H)
  rendered from the scene's camera (`frames`' third item) with vertical field of view fovy
  (deg, the model's `vis.global_.fovy`)."""
  # the scene holds two eyes half the model's interpupillary distance either side: the
  # picture (mono) is taken from their midpoint
  pos = (np.array(scene.camera[0].pos, float) + np.array(scene.camera[1].pos, float)) / 2
  forward, up = (np.array(v, float) for v in (scene.camera[0].forward, scene.camera[0].up))
  right = np.cross(forward, up)
  d = np.asarray(point, float) - pos
  x, y, z = d @ right, d @ up, d @ forward
  width, height = size
  f = (height / 2) / np.tan(np.radians(fovy) / 2)
  return int(round(height / 2 - f * y / z)), int(round(width / 2 + f * x / z))


def save_png(image: np.ndarray, out: pathlib.Path) -> pathlib.Path:
  import matplotlib
  matplotlib.use("Agg", force=True)
  import matplotlib.pyplot as plt
  out = pathlib.Path(out)
  out.parent.mkdir(parents=True, exist_ok=True)
  plt.imsave(out, image)
  return out


def save_video(images: Iterator[np.ndarray], out: pathlib.Path, fps: int = FPS) -> pathlib.Path:
  try:
    import imageio.v2 as imageio
  except ImportError:
    raise errors.SettingError("--video needs imageio and its ffmpeg: pip install -e "
                              "'.[video]' (imageio, imageio-ffmpeg)") from None
  out = pathlib.Path(out)
  out.parent.mkdir(parents=True, exist_ok=True)
  with imageio.get_writer(out, fps=fps, macro_block_size=1) as writer:
    for image in images:
      writer.append_data(image)
  return out


def main(argv: Optional[list[str]] = None) -> int:
  parser = argparse.ArgumentParser(prog="python -m sim.render", description=__doc__.split(
      "\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
      epilog=__doc__.split("\n\n", 2)[2])
  parser.add_argument("rig", choices=RIGS)
  parser.add_argument("--out", type=cli.path_arg, default=None, help="PNG (default RIG.png)")
  parser.add_argument("--time", type=float, default=None,
                      help="simulated seconds before the picture (default: halfway along the "
                           "footpad's path; 0.25 s of settling for the shell)")
  parser.add_argument("--video", type=cli.path_arg, default=None,
                      help=f"also an MP4 of the whole run at {FPS} frames/s")
  parser.add_argument("--path", default=None, help="footpad: the paper's path to run "
                                                     "(default x_stroke)")
  parser.add_argument("--z", type=float, default=None, help="footpad: depth, mm (default 1)")
  parser.add_argument("--size", default="640x480", help="image size WxH, px (640x480)")
  args = parser.parse_args(argv)
  return cli.run(lambda: _render(args), "sim.render")


def _render(args) -> int:
  try:
    width, height = (int(v) for v in args.size.lower().split("x"))
  except ValueError:
    raise errors.SettingError(f"--size {args.size!r} is not WxH (e.g. 640x480)") from None
  if args.rig == "shell" and (args.path is not None or args.z is not None):
    raise errors.SettingError("--path and --z choose the footpad's CNC run: the shell settles "
                              "on its springs (drop them, or render footpad)")
  args.path = "x_stroke" if args.path is None else args.path
  args.z = 1.0 if args.z is None else args.z
  if not (np.isfinite(args.z) and 0.0 <= args.z <= 10.0):
    raise errors.SettingError(f"--z {args.z:g} is out of range: allowed 0 to 10 mm")
  out = files.output_file(args.out or pathlib.Path(f"{args.rig}.png"), "--out", (".png",))
  if args.video is not None:
    files.output_file(args.video, "--video", VIDEO_SUFFIXES)
  choose_backend()
  kw = dict(size=(width, height), path=args.path, z=args.z * 1e-3)
  run = rig_run(args.rig, args.path, args.z * 1e-3)
  seconds = run[2]
  t = seconds / 2 if args.time is None else args.time
  if not 0 <= t <= seconds:
    raise errors.SettingError(f"--time {t:g} is out of range: allowed 0 to {seconds:g} s "
                              f"for this run")
  (_, image, _), = frames(args.rig, [t], **kw, run=run)
  out = save_png(image, out)
  print(f"wrote {out} ({args.rig} at t = {t:.3f} s)")
  if args.video is not None:
    times = list(np.arange(0.0, seconds, 1.0 / FPS))
    video = save_video((im for _, im, _ in frames(args.rig, times, **kw)), args.video)
    print(f"wrote {video} ({len(times)} frames, {seconds:.2f} s)")
  return 0


if __name__ == "__main__":
  sys.exit(main())
