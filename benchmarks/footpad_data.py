"""The footpad datasets of the LSANN paper's protocol, shared by the footpad benchmarks."""

from __future__ import annotations

import dataclasses

from sim import footpad

TRAIN_PATHS = ("z_press", "x_stroke", "y_stroke", "asterisk", "circular")
TEST_PATHS = ("test_path_1", "test_path_2")
# Every effect of the paper's bench whose magnitude has a stated source (p_delta has no free
# parameter); the assumed viscoelastic relaxation stays opt-in (--set effects=...).
DEFAULT_EFFECTS = ("friction", "p_delta", "sensor_noise", "gain_offset_spread",
                   "adc_quantisation", "adc_saturation", "ft_noise")
QUICK_Z_LEVELS = (0.0005, 0.001, 0.0015)


def scenes(quick: bool, seed: int, overrides: dict[str, str]) -> dict[str, footpad.FootpadScene]:
  """{"train": ..., "test": ...}; --quick runs three Z levels instead of the paper's sixteen."""
  base = footpad.FootpadScene(effects=DEFAULT_EFFECTS, seed=seed,
                              z_levels=QUICK_Z_LEVELS if quick else footpad.PAPER_Z_LEVELS)
  base = base.with_overrides(overrides)
  base.validate()
  return {"train": dataclasses.replace(base, paths=TRAIN_PATHS),
          "test": dataclasses.replace(base, paths=TEST_PATHS)}
