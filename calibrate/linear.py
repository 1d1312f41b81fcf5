"""Linear least squares (LSANN paper Eqns 1-4, with a bias column), solved by pivoted QR on
standardised features with an explicit rank cut-off: never by forming (V^T V)^-1."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import scipy.linalg


@dataclasses.dataclass(frozen=True)
class LinearFit:
  """F ~ ((V - mean) / scale) @ coef + bias.

  Attributes:
    mean, scale: (C,) feature standardisation; scale 0 marks a dropped (constant) channel.
    coef: (C, A) coefficients on standardised features.
    bias: (A,) intercept.
    rank: numerical rank used.
  """
  mean: np.ndarray
  scale: np.ndarray
  coef: np.ndarray
  bias: np.ndarray
  rank: int

  def predict(self, v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    z = np.divide(v - self.mean, self.scale, out=np.zeros_like(v), where=self.scale > 0)
    return z @ self.coef + self.bias


def fit_linear(v: np.ndarray, f: np.ndarray, rcond: float = 1e-10) -> LinearFit:
  """Least-squares fit of f (N, A) on counts v (N, C) plus a bias."""
  v = np.asarray(v, dtype=np.float64)
  f = np.asarray(f, dtype=np.float64)
  if v.ndim != 2 or f.ndim != 2 or len(v) != len(f):
    raise ValueError(f"counts {v.shape} and forces {f.shape} must be (N, C) and (N, A) with the "
                     f"same N")
  bad = ~(np.isfinite(v).all(axis=1) & np.isfinite(f).all(axis=1))
  if bad.any():
    raise ValueError(f"{bad.sum()} of {len(v)} rows hold NaN or inf: drop them first")
  if len(v) <= v.shape[1] + 1:
    raise ValueError(f"{len(v)} samples cannot fit {v.shape[1] + 1} parameters per axis")
  mean = v.mean(axis=0)
  scale = v.std(axis=0)
  dead = scale <= 1e-12 * np.maximum(np.abs(mean), 1.0)
  if dead.any():
    warnings.warn(f"channels {np.flatnonzero(dead).tolist()} are constant: dropped from the fit")
  scale = np.where(dead, 0.0, scale)
  z = np.divide(v - mean, scale, out=np.zeros_like(v), where=scale > 0)
  a = np.column_stack([z[:, ~dead], np.ones(len(z))])
  q, r, perm = scipy.linalg.qr(a, mode="economic", pivoting=True)
  d = np.abs(np.diag(r))
  rank = int(np.sum(d > rcond * d[0]))
  if rank < a.shape[1]:
    warnings.warn(f"features are rank-deficient ({rank} of {a.shape[1]}): "
                  f"{a.shape[1] - rank} direction(s) dropped")
  sol = np.zeros((a.shape[1], f.shape[1]))
  sol[perm[:rank]] = scipy.linalg.solve_triangular(r[:rank, :rank], q[:, :rank].T @ f)
  coef = np.zeros((v.shape[1], f.shape[1]))
  coef[~dead] = sol[:-1]
  return LinearFit(mean, scale, coef, sol[-1], rank)
