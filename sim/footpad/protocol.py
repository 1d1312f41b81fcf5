"""The LSANN paper's data protocol (Sec. III-B, III-C): the training and test recordings."""

from __future__ import annotations

import dataclasses

from sim.footpad import scene as scene_lib

TRAIN_PATHS = ("z_press", "x_stroke", "y_stroke", "asterisk", "circular")
LS_PATHS = ("z_press", "x_stroke", "y_stroke")  # the linear fit's data (Sec. III-B)
TEST_PATHS = ("test_path_1", "test_path_2")
# Every effect of the paper's bench whose magnitude has a stated source or range (p_delta has
# no free parameter), ranged ones at their nominal values (`footpad_envelope` spans them).
DEFAULT_EFFECTS = ("friction", "pressure_friction", "stick_slip", "viscoelastic", "p_delta",
                   "hysteresis",
                   "thermal_drift", "sensor_noise", "gain_offset_spread", "adc_quantisation",
                   "adc_saturation", "ft_noise")
QUICK_Z_LEVELS = (0.0005, 0.001, 0.0015)


def base(quick: bool, seed: int) -> scene_lib.FootpadScene:
  """The protocol's scene before the user's settings; --quick runs three Z levels instead of
  the paper's sixteen."""
  return scene_lib.FootpadScene(effects=DEFAULT_EFFECTS, seed=seed,
                                z_levels=QUICK_Z_LEVELS if quick else scene_lib.PAPER_Z_LEVELS)


def scenes(scene: scene_lib.FootpadScene) -> dict[str, scene_lib.FootpadScene]:
  """{"train": ..., "test": ...}: `scene` (from `base`, with the user's settings) on the
  paper's training and test paths; with a `custom_path`, a third, "custom", runs that file
  alone."""
  scene.validate()
  out = {"train": dataclasses.replace(scene, paths=TRAIN_PATHS, custom_path=None),
         "test": dataclasses.replace(scene, paths=TEST_PATHS, custom_path=None)}
  if scene.custom_path is not None:
    out["custom"] = dataclasses.replace(scene, paths=())
  return out


def splits(train, test, nn_paths: tuple[str, ...] = ("asterisk",)) -> dict:
  """The protocol's data from its training and test recordings, on their paths at their
  indentation: {"linear": the Z presses and X/Y strokes LS fits, "net": `nn_paths` the
  networks train on (Sec. III-C), "test": every test path}."""
  return {"linear": train.on_path(*LS_PATHS), "net": train.on_path(*nn_paths),
          "test": test.on_path()}

