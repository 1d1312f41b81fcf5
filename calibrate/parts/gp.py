"""A Gaussian process (scikit-learn's `GaussianProcessRegressor`) as a part: LSGP is LS plus
a GP fitted on its residual.

The kernel is a constant times an RBF with one length scale per input channel, plus white
noise; its hyperparameters are fitted by maximum marginal likelihood (scikit-learn, L-BFGS)
on `GPConfig.points` training samples spread evenly over the training data (a GP costs the
cube of its points to fit and its points times the inputs to evaluate). What it keeps is
plain arrays: its points (standardised, divided by the length scales), their weights alpha
(the signal variance folded in) and the output scaling. Far from its points the RBF decays
and the residual goes to zero: LSGP returns to LS's plane.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from calibrate.cexport.emitter import literal
from calibrate.parts.base import Part, check_shapes
from util import fields
from util.fields import setting


@fields.declared
@dataclasses.dataclass(frozen=True)
class GPConfig:
  """Fit settings.

  Attributes:
    points: training samples the GP keeps, spread evenly over the data. Its fit grows
      faster than their square (measured, 4 inputs and 3 outputs on a 2-core machine: 100
      points 1.5 s, 200 5.5 s, 300 12 s per fit; a cross-validated fit makes folds + 2).
    restarts: extra starts of the hyperparameter search from random points (0: one).
  """
  points: int = setting(150, "[10, 3000]")
  restarts: int = setting(0, "[0, 20]")

  def validate(self) -> None:
    fields.check(self)


Config = GPConfig  # the name a recipe asks a family for (`calibrate.methods.ResidualRecipe`)


@dataclasses.dataclass(frozen=True)
class GP(Part):
  """A fitted GP's mean: y = y_mean + y_scale * sum_m alpha[m] exp(-|s - points[m]|^2 / 2),
  s = (x - x_mean) / x_scale.

  Attributes:
    x_mean, x_scale: (C,) the inputs' standardisation, the length scales folded into
      x_scale.
    points: (M, C) the kept training inputs, standardised.
    alpha: (M, A) their weights (the kernel's signal variance folded in).
    y_mean, y_scale: (A,) the outputs' scaling.
  """
  x_mean: np.ndarray
  x_scale: np.ndarray
  points: np.ndarray
  alpha: np.ndarray
  y_mean: np.ndarray
  y_scale: np.ndarray

  NAME, C_TAG, LABEL = "gp", "GP", "GP"
  RESIDUAL_LABEL = "LSGP"
  FIELDS = ("x_mean", "x_scale", "points", "alpha", "y_mean", "y_scale")

  @property
  def n_inputs(self) -> int:
    return len(self.x_mean)

  @property
  def n_outputs(self) -> int:
    return len(self.y_mean)

  @property
  def tame(self) -> bool:
    return False  # between and near its points it bends as the data did

  def predict(self, x: np.ndarray) -> np.ndarray:
    s = (np.asarray(x, float) - self.x_mean) / self.x_scale
    d2 = (np.sum(s ** 2, axis=1)[:, None] - 2 * s @ self.points.T
          + np.sum(self.points ** 2, axis=1)[None, :])
    return np.exp(-0.5 * np.maximum(d2, 0.0)) @ self.alpha * self.y_scale + self.y_mean

  def without_outputs(self, outputs: np.ndarray) -> "GP":
    """The GP with its contribution removed on `outputs` (bool (A,)): exactly 0 there."""
    return dataclasses.replace(self, alpha=np.where(outputs[None, :], 0.0, self.alpha),
                               y_mean=np.where(outputs, 0.0, self.y_mean))

  def leaves(self) -> tuple[dict, dict]:
    return {f: getattr(self, f) for f in self.FIELDS}, {}

  @classmethod
  def from_leaves(cls, spec, arrays, children=None) -> "GP":
    gp = cls(*(arrays[f] for f in cls.FIELDS))
    (m, c), a = np.shape(gp.points) if np.ndim(gp.points) == 2 else (-1, -1), \
        np.shape(gp.y_mean)[0] if np.ndim(gp.y_mean) == 1 else -1
    check_shapes("Gaussian process", arrays, {"x_mean": (c,), "x_scale": (c,),
                                              "alpha": (m, a), "y_scale": (a,)})
    return gp

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> None:
    """The kernel against every kept point; expf costed as a tanhf."""
    m, c = self.points.shape
    a = self.alpha.shape[1]
    xm, xi = em.array(f"{tag}_XMEAN", self.x_mean), em.array(f"{tag}_XINV", 1 / self.x_scale)
    pts, alpha = em.array(f"{tag}_POINTS", self.points), em.array(f"{tag}_ALPHA", self.alpha)
    ym, ys = em.array(f"{tag}_YMEAN", self.y_mean), em.array(f"{tag}_YSCALE", self.y_scale)
    em.costs(macs=m * (2 * c + a) + c + 2 * a, tanh=m, stack=4 * (c + a))
    em.code += [
        f"  {{ /* Gaussian process: RBF kernel against {m} kept points */",
        f"    float s[{c}], e[{a}];",
        f"    for (int i = 0; i < {c}; ++i) s[i] = (x[i] - {xm}[i]) * {xi}[i];",
        f"    for (int j = 0; j < {a}; ++j) e[j] = 0.0f;",
        f"    for (int m = 0; m < {m}; ++m) {{",
        "      float d = 0.0f;",
        f"      for (int i = 0; i < {c}; ++i) {{",
        f"        float t = s[i] - {pts}[m * {c} + i];",
        "        d += t * t;",
        "      }",
        f"      float k = expf({literal(-0.5)} * d);",
        f"      for (int j = 0; j < {a}; ++j) e[j] += {alpha}[m * {a} + j] * k;",
        "    }",
        f"    for (int j = 0; j < {a}; ++j) {acc}[j] += e[j] * {ys}[j] + {ym}[j];",
        "  }"]


def fit(x: np.ndarray, y: np.ndarray, config: GPConfig = GPConfig(), seed: int = 0) -> GP:
  """A GP on (N, C) inputs and (N, A) targets: `config.points` samples spread evenly over
  the N, the kernel's hyperparameters by maximum marginal likelihood (one set for all
  outputs)."""
  from sklearn.exceptions import ConvergenceWarning
  from sklearn.gaussian_process import GaussianProcessRegressor
  from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
  config.validate()
  keep = np.unique(np.linspace(0, len(x) - 1, min(config.points, len(x))).round().astype(int))
  xs, ys = np.asarray(x, float)[keep], np.asarray(y, float)[keep]
  x_mean, x_sd = xs.mean(axis=0), xs.std(axis=0)
  x_sd = np.where(x_sd > 0, x_sd, 1.0)
  y_mean, y_sd = ys.mean(axis=0), ys.std(axis=0)
  y_sd = np.where(y_sd > 0, y_sd, 1.0)
  kernel = ConstantKernel(1.0, (1e-3, 1e3)) * RBF(np.ones(x.shape[1]), (1e-2, 1e3)) \
      + WhiteKernel(1e-2, (1e-8, 1e1))
  with warnings.catch_warnings():
    # a length scale at its upper bound: the residual does not depend on that channel
    warnings.filterwarnings("ignore", "The optimal value found for dimension",
                            ConvergenceWarning)
    gpr = GaussianProcessRegressor(kernel, normalize_y=False,
                                   n_restarts_optimizer=config.restarts,
                                   random_state=seed).fit((xs - x_mean) / x_sd,
                                                          (ys - y_mean) / y_sd)
  signal, rbf = gpr.kernel_.k1.k1.constant_value, gpr.kernel_.k1.k2
  scale = x_sd * np.broadcast_to(rbf.length_scale, x_mean.shape)
  alpha = np.asarray(gpr.alpha_).reshape(len(keep), -1) * signal
  return GP(x_mean, scale, (xs - x_mean) / scale, alpha, y_mean, y_sd)
