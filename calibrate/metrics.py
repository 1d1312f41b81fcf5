"""The papers' accuracy metrics (LSANN paper Eqns 5, 6, 9)."""

from __future__ import annotations

import numpy as np


def rmse(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
  """Root mean squared error per column (Eqn 5)."""
  return np.sqrt(np.mean((np.asarray(pred) - truth) ** 2, axis=0))


def nrmse_pct(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
  """RMSE as % of the range of the truth (Eqn 6)."""
  return 100.0 * rmse(pred, truth) / np.ptp(truth, axis=0)


def r2_pct(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
  """Coefficient of determination, % (Eqn 9)."""
  ss_res = np.sum((truth - pred) ** 2, axis=0)
  ss_tot = np.sum((truth - np.mean(truth, axis=0)) ** 2, axis=0)
  return 100.0 * (1.0 - ss_res / ss_tot)
