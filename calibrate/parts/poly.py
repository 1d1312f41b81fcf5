"""A total-degree polynomial with cross terms, ridge-regularised, that grows only linearly
outside the box it was fitted in.

The shell paper's pseudoinverse (`linear.fit_linear(degree=3)`) takes powers of each channel
alone: it cannot express a coupling between channels (a product s_1 s_2), and a cube
evaluated beyond the training range explodes (R^2 of -2480 % across recordings on a real
sensor). Here the features are every monomial of the standardised inputs z of total degree
1..d (`powers`), fitted with a ridge weight by SVD of the centred features (never forming
the normal matrix), and the prediction outside the training box [lo, hi] of z continues
along the tangent plane at the point c where the line from the box's centre to z leaves
the box: f(z) = f(c) + grad f(c) . (z - c), c = `base.toward_centre`(z, lo, hi). Inside
the box it is the polynomial itself, identical to scikit-learn's
`PolynomialFeatures(d, include_bias=False)` + `Ridge(alpha)` on the same z.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import scipy.linalg

from calibrate.parts.base import (Part, box_point, check_shapes, clip_c, emit_box_point,
                                  read_beyond)
from util import errors


def powers(channels: int, degree: int, cross: bool = True) -> np.ndarray:
  """(T, C) exponents of the monomials of total degree 1..degree in graded order (all
  products with `cross`; each channel's own powers without)."""
  if not (isinstance(degree, (int, np.integer)) and 1 <= degree <= 5):
    raise errors.SettingError(f"degree={degree!r} is out of range: allowed integers 1..5")
  rows = []
  for d in range(1, degree + 1):
    for combo in itertools.combinations_with_replacement(range(channels), d):
      if not cross and len(set(combo)) > 1:
        continue
      e = np.zeros(channels, int)
      for c in combo:
        e[c] += 1
      rows.append(e)
  return np.array(rows, int).reshape(-1, channels)


def monomials(z: np.ndarray, p: np.ndarray) -> np.ndarray:
  """(N, T) the monomials z^p of (N, C) inputs, by repeated products (exponents <= 5)."""
  out = np.ones((len(z), len(p)))
  for c in range(p.shape[1]):
    for k in range(1, int(p[:, c].max(initial=0)) + 1):
      out[:, p[:, c] >= k] *= z[:, c:c + 1]
  return out


def gradient(z: np.ndarray, p: np.ndarray, coef: np.ndarray) -> np.ndarray:
  """(N, A, C) gradient of the polynomial sum_t coef[t] z^p[t] at z (N, C)."""
  n, c = z.shape
  out = np.zeros((n, coef.shape[1], c))
  for j in range(c):
    has = p[:, j] > 0
    if not has.any():
      continue
    lower = p[has].copy()
    lower[:, j] -= 1
    out[:, :, j] = (monomials(z, lower) * p[has, j]) @ coef[has]
  return out


@dataclasses.dataclass(frozen=True)
class PolyFit(Part):
  """F ~ bias + monomials(z) @ coef, z = (x - mean) / scale, continued linearly beyond the
  training box [lo, hi] of z.

  Attributes:
    mean, scale: (C,) standardisation of the inputs (scale 1 for a constant channel).
    lo, hi: (C,) the training box, standardised units.
    powers: (T, C) exponents of the monomials.
    coef: (T, A) coefficients.  bias: (A,) intercept, output units.
    ridge: the ridge weight it was fitted with (on the sum of squares, as scikit-learn's
      `Ridge(alpha)`).
    rank: numerical rank of the centred features.
    beyond: where past the box its tangent is taken: "centre", where the line from the
      box's centre leaves the box (`base.toward_centre`); "clip", each input clipped alone
      (files written before 2026-11-27).
  """
  mean: np.ndarray
  scale: np.ndarray
  lo: np.ndarray
  hi: np.ndarray
  powers: np.ndarray
  coef: np.ndarray
  bias: np.ndarray
  ridge: float
  rank: int
  beyond: str = "centre"

  @property
  def degree(self) -> int:
    return int(self.powers.sum(axis=1).max())

  def standardise(self, x: np.ndarray) -> np.ndarray:
    return (np.asarray(x, float) - self.mean) / self.scale

  def predict(self, x: np.ndarray) -> np.ndarray:
    """(N, A) outputs from (N, C) inputs: the polynomial inside the training box, outside it
    its tangent plane where the line from the box's centre leaves the box."""
    z = self.standardise(x)
    c = box_point(z, self.lo, self.hi, self.beyond)
    f = monomials(c, self.powers) @ self.coef + self.bias
    out = np.any(z != c, axis=1)
    if out.any():
      g = gradient(c[out], self.powers, self.coef)
      f[out] += np.einsum("nac,nc->na", g, z[out] - c[out])
    return f

  NAME, C_TAG, LABEL = "poly", "POLY", "POLY"
  FIELDS = ("mean", "scale", "lo", "hi", "powers", "coef", "bias")

  @property
  def n_inputs(self) -> int:
    return len(self.mean)

  @property
  def n_outputs(self) -> int:
    return self.coef.shape[1]

  def leaves(self) -> tuple[dict, dict]:
    return {f: getattr(self, f) for f in self.FIELDS}, {"ridge": self.ridge, "rank": self.rank,
                                                        "beyond": self.beyond}

  @classmethod
  def from_leaves(cls, spec, arrays, children=None) -> "PolyFit":
    fit = cls(*(arrays[f] for f in ("mean", "scale", "lo", "hi")),
              np.asarray(arrays["powers"]).astype(int), arrays["coef"], arrays["bias"],
              float(spec["ridge"]), int(spec["rank"]), read_beyond(spec))
    c, (t, a) = len(fit.mean), np.shape(fit.coef) if np.ndim(fit.coef) == 2 else (-1, -1)
    check_shapes("polynomial", arrays, {"scale": (c,), "lo": (c,), "hi": (c,),
                                        "powers": (t, c), "bias": (a,)})
    return fit

  def _box_point_c(self, mean: str, inv: str, lo: str, hi: str, c: int) -> list[str]:
    """z[] standardised, zc[] its point on the box, dz[] = z - zc and `outside` (in one loop
    for "clip", as files written before keep their C)."""
    step = ["      dz[i] = z[i] - zc[i];", "      outside |= dz[i] != 0.0f;", "    }"]
    if self.beyond == "clip":
      return [f"    for (int i = 0; i < {c}; ++i) {{",
              f"      z[i] = (x[i] - {mean}[i]) * {inv}[i];",
              f"      zc[i] = {clip_c('z', lo, hi)};",
              *step]
    return [f"    for (int i = 0; i < {c}; ++i) z[i] = (x[i] - {mean}[i]) * {inv}[i];",
            *emit_box_point(lo, hi, "z", "zc", c, self.beyond),
            f"    for (int i = 0; i < {c}; ++i) {{", *step]

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> None:
    """The polynomial, continued along its tangent plane beyond the training box, as
    `predict` does."""
    t, a = self.coef.shape
    mean, inv = em.array(f"{tag}_MEAN", self.mean), em.array(f"{tag}_INV_SCALE", 1 / self.scale)
    lo, hi = em.array(f"{tag}_LO", self.lo), em.array(f"{tag}_HI", self.hi)
    coef, bias = em.array(f"{tag}_COEF", self.coef), em.array(f"{tag}_BIAS", self.bias)
    pw = em.bytes_(f"{tag}_POW", self.powers)
    em.costs(macs=t * (self.degree + a), stack=12 * c)
    em.code += [
        f"  {{ /* polynomial with cross terms, degree {self.degree}, {t} terms; linear beyond "
        f"the training box */",
        f"    float z[{c}], zc[{c}], dz[{c}];",
        "    int outside = 0;",
        *self._box_point_c(mean, inv, lo, hi, c),
        f"    for (int j = 0; j < {a}; ++j) {acc}[j] += {bias}[j];",
        f"    for (int t = 0; t < {t}; ++t) {{",
        f"      const unsigned char *e = &{pw}[t * {c}];",
        f"      const float *row = &{coef}[t * {a}];",
        "      float m = 1.0f;",
        f"      for (int i = 0; i < {c}; ++i)",
        "        for (int k = 0; k < e[i]; ++k) m *= zc[i];",
        f"      for (int j = 0; j < {a}; ++j) {acc}[j] += row[j] * m;",
        "      if (!outside) continue;",
        f"      for (int v = 0; v < {c}; ++v) {{ /* the tangent plane's slope along z[v] */",
        "        if (e[v] == 0 || dz[v] == 0.0f) continue;",
        "        float g = (float)e[v];",
        f"        for (int i = 0; i < {c}; ++i)",
        "          for (int k = 0; k < e[i] - (i == v); ++k) g *= zc[i];",
        f"        for (int j = 0; j < {a}; ++j) {acc}[j] += row[j] * g * dz[v];",
        "      }",
        "    }",
        "  }"]


@dataclasses.dataclass(frozen=True)
class _Factored:
  """The centred monomials of standardised inputs, factored once for any ridge weight."""
  mean: np.ndarray
  scale: np.ndarray
  lo: np.ndarray
  hi: np.ndarray
  powers: np.ndarray
  m_mean: np.ndarray
  y_mean: np.ndarray
  s: np.ndarray
  vt: np.ndarray
  uty: np.ndarray
  keep: np.ndarray

  def solve(self, ridge: float) -> PolyFit:
    """The fit at one ridge weight: coef = V diag(s / (s^2 + ridge)) U^T (y - mean y)."""
    d = np.where(self.keep, self.s / (self.s ** 2 + ridge), 0.0)
    coef = self.vt.T @ (d[:, None] * self.uty)
    return PolyFit(self.mean, self.scale, self.lo, self.hi, self.powers, coef,
                   self.y_mean - self.m_mean @ coef, float(ridge), int(self.keep.sum()))


def factor(x: np.ndarray, y: np.ndarray, degree: int, cross: bool, rcond: float) -> _Factored:
  mean, scale = x.mean(axis=0), x.std(axis=0)
  scale = np.where(scale > 1e-12 * np.maximum(np.abs(mean), 1e-300), scale, 1.0)
  z = (x - mean) / scale
  p = powers(x.shape[1], degree, cross)
  m = monomials(z, p)
  m_mean, y_mean = m.mean(axis=0), y.mean(axis=0)
  u, s, vt = scipy.linalg.svd(m - m_mean, full_matrices=False)
  keep = s > rcond * s[0] if s.size and s[0] > 0 else np.zeros(len(s), bool)
  return _Factored(mean, scale, z.min(axis=0), z.max(axis=0), p, m_mean, y_mean, s, vt,
                   u.T @ (y - y_mean), keep)


def fit(x: np.ndarray, y: np.ndarray, degree: int, ridge: float = 0.0, cross: bool = True,
        rcond: float = 1e-10) -> PolyFit:
  """Ridge least squares of y (N, A) on the monomials of the standardised x (N, C).

  Minimises |y - b - M coef|^2 + ridge |coef|^2 (the bias unpenalised) through the SVD of
  the centred monomials M, singular values below rcond x the largest dropped (then it warns
  how many, unless a ridge weight regularises them).
  """
  import warnings
  if not (np.isfinite(ridge) and ridge >= 0):
    raise errors.SettingError(f"ridge={ridge!r} is out of range: allowed [0, inf)")
  f = factor(x, y, degree, cross, rcond)
  out = f.solve(ridge)
  if out.rank < len(f.powers) and ridge == 0:
    warnings.warn(f"polynomial features are rank-deficient ({out.rank} of {len(f.powers)}): "
                  f"{len(f.powers) - out.rank} direction(s) dropped")
  return out


RIDGES = (0.0,) + tuple(10.0 ** k for k in range(-8, 1))  # times the number of samples
