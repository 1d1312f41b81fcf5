"""Rendered rigs: lit (not blank), and the rig's pixels where its geometry projects."""

import numpy as np
import pytest

from sim import render

SIZE = (320, 240)


def _frame(rig, segmentation=False, **kw):
  try:
    (_, image, scene), = render.frames(rig, [0.3], SIZE, segmentation=segmentation, **kw)
  except render.errors.SimulationError as err:  # no GL library on this machine
    pytest.skip(str(err))
  return image, scene


@pytest.mark.parametrize("rig", render.RIGS)
def test_the_rig_is_lit_not_blank(rig):
  image, _ = _frame(rig)
  assert image.shape == (SIZE[1], SIZE[0], 3) and image.dtype == np.uint8
  gray = image.mean(axis=2)
  assert gray.std() > 20  # a picture, not a flat fill
  assert np.percentile(gray, 97) > 90  # lit: the models had no lights and rendered ~black


@pytest.mark.parametrize("rig, body", [("footpad", "carriage"), ("shell", "shell")])
def test_the_rigs_pixels_are_where_its_geometry_projects(rig, body):
  import mujoco
  seg, scene = _frame(rig, segmentation=True)
  model, step_to, _, _ = render.rig_run(rig)
  data = step_to(0.3)
  ids = [g for g in range(model.ngeom)
         if mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[g]) == body]
  assert ids, f"no geom on body {body!r}"
  hits = 0
  for g in ids:
    row, col = render.project(scene, data.geom_xpos[g], SIZE, model.vis.global_.fovy)
    assert 0 <= row < SIZE[1] and 0 <= col < SIZE[0]
    window = seg[max(row - 1, 0):row + 2, max(col - 1, 0):col + 2, 0]
    hits += bool(np.isin(window, ids).any())  # the body's own geoms may hide each other
  assert hits >= 1 and hits >= 0.5 * len(ids), (hits, len(ids))


def test_a_video_holds_the_frames_it_was_given(tmp_path):
  iio = pytest.importorskip("imageio.v3", reason="video is an optional extra: .[video]")
  try:
    shots = [im for _, im, _ in render.frames("footpad", [0.0, 0.5, 1.0, 1.5], SIZE)]
  except render.errors.SimulationError as err:
    pytest.skip(str(err))
  path = render.save_video(iter(shots), tmp_path / "f.mp4", fps=10)
  back = iio.imread(path)
  assert back.shape == (4, SIZE[1], SIZE[0], 3)
  # lossy compression: each frame close to the one given, and the run moves between them
  assert np.abs(back.astype(float) - np.stack(shots)).mean() < 8
  assert np.abs(np.diff(np.stack(shots).astype(float), axis=0)).mean() > 0.1


def test_the_shell_shows_each_photointerrupters_beam():
  import mujoco
  image, scene = _frame("shell")
  beams = [g for g in scene.geoms[:scene.ngeom]
           if g.type == mujoco.mjtGeom.mjGEOM_LINE and g.objid == -1]
  assert len(beams) == 8
  # a beam is as long as the sensor's ray to its facet: 2-4 mm, the sensors' window
  assert all(1.5e-3 < g.size[2] < 4.5e-3 for g in beams), [g.size[2] for g in beams]
  red = (image[..., 0] > 150) & (image[..., 1] < 80) & (image[..., 2] < 80)
  assert red.sum() > 50


def test_importing_render_leaves_the_environment_alone():
  """The GL backend is chosen by the command or by `choose_backend()`, never by an import."""
  import subprocess
  import sys
  code = ("import os; os.environ.pop('MUJOCO_GL', None); import sim.render; "
          "print(os.environ.get('MUJOCO_GL'))")
  env = {k: v for k, v in __import__("os").environ.items() if k != "MUJOCO_GL"}
  out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       check=True).stdout.strip()
  assert out == "None"
