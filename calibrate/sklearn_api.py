"""A scikit-learn-style face for the estimators: `fit`, `predict`, `score`, `get_params`,
`set_params`, for pipelines and model selection written for that ecosystem. scikit-learn
itself is not needed (the class follows its estimator conventions by duck typing).

    from calibrate.sklearn_api import ForceCalibrator
    model = ForceCalibrator(method="lsann", seed=0).fit(counts, forces)
    r2 = model.score(test_counts, test_forces)   # R2, uniform average over the outputs
"""

from __future__ import annotations

import numpy as np

from calibrate import estimators, metrics
from calibrate.parts import mlp

_PARAMS = ("method", "hidden", "epochs", "degree", "ensemble", "val_fraction", "seed")


class ForceCalibrator:
  """An estimator of forces from sensor counts, settings as constructor arguments.

  Args:
    method: "ls", "poly", "lsann" or "nn".  hidden, epochs: the network's.
    degree: the polynomial's.  ensemble: networks from that many seeds.
    val_fraction: held out for early stopping and the residual spread.  seed: one integer.

  Attributes (after fit):
    estimator_: the fitted `estimators.Estimator`.  n_features_in_: input channels.
  """

  def __init__(self, method: str = "lsann", hidden: int = 10, epochs: int = 1000,
               degree: int = 3, ensemble: int = 1, val_fraction: float = 0.15, seed: int = 0):
    self.method = method
    self.hidden = hidden
    self.epochs = epochs
    self.degree = degree
    self.ensemble = ensemble
    self.val_fraction = val_fraction
    self.seed = seed

  def get_params(self, deep: bool = True) -> dict:
    return {k: getattr(self, k) for k in _PARAMS}

  def set_params(self, **params) -> "ForceCalibrator":
    for k, v in params.items():
      if k not in _PARAMS:
        raise ValueError(f"unknown parameter {k!r}: allowed {', '.join(_PARAMS)}")
      setattr(self, k, v)
    return self

  def fit(self, X, y) -> "ForceCalibrator":
    y = np.asarray(y, float)
    y2 = y[:, None] if y.ndim == 1 else y
    self._one_output = y.ndim == 1
    self.estimator_ = estimators.fit(
        estimators.Kind(str(self.method).upper()), X, y2,
        config=mlp.LMConfig(hidden=self.hidden, epochs=self.epochs), degree=self.degree,
        ensemble=self.ensemble, val_fraction=self.val_fraction, seed=self.seed)
    self.n_features_in_ = self.estimator_.n_inputs
    return self

  def predict(self, X, return_std: bool = False):
    """(N, A) forces (N, for one target column), with their (N, A) spreads if asked."""
    if not hasattr(self, "estimator_"):
      raise RuntimeError("ForceCalibrator is not fitted yet: call fit(X, y) first")
    out = self.estimator_.predict(X, return_std=return_std)
    if self._one_output:
      out = tuple(o[:, 0] for o in out) if return_std else out[:, 0]
    return out

  def score(self, X, y) -> float:
    """R2 (a fraction, as scikit-learn's `r2_score`), averaged over the outputs."""
    y = np.asarray(y, float)
    pred = np.asarray(self.predict(X), float)
    y2, p2 = (y[:, None], pred[:, None]) if y.ndim == 1 else (y, pred)
    return float(np.mean(metrics.r2_pct(p2, y2)) / 100.0)
