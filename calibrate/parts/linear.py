"""Linear and polynomial least squares from die counts to forces.

`fit_linear` is the LSANN paper's multivariate least squares (Eqns 1-4, with a bias column);
with `degree=3` it is the force-sensing-shell paper's polynomial pseudoinverse (features s,
s^2, s^3 per channel, its Eqns 4-9). Both solve through standardised features by pivoted QR
or by SVD with an explicit rank cut-off, never by forming (V^T V)^-1. Powers are taken of the
standardised counts: the same polynomial space as powers of raw 12-bit counts (cubes up to
7e10) without their 1e15 column-scale spread.
"""

from __future__ import annotations

import dataclasses
import enum
import warnings

import numpy as np
import scipy.linalg
import scipy.linalg.lapack

from calibrate.parts.base import Part, check_shapes
from util import errors


class Method(enum.Enum):
  QR = "qr"
  SVD = "svd"


@dataclasses.dataclass(frozen=True)
class LinearFit(Part):
  """F ~ features(V) @ coef + bias, features = powers 1..degree of (V - mean) / scale.

  Attributes:
    mean, scale: (C,) standardisation of the counts; scale 0 marks a dropped constant channel.
    coef: (C * degree, A) coefficients, powers of channel c in rows c, C + c, 2C + c...
    bias: (A,) intercept, force units.
    rank: numerical rank used, counting the bias column.
    degree: polynomial degree (1: linear).
  """
  mean: np.ndarray
  scale: np.ndarray
  coef: np.ndarray
  bias: np.ndarray
  rank: int
  degree: int = 1

  def features(self, v: np.ndarray) -> np.ndarray:
    """(N, C * degree) standardised counts and their powers; dropped channels give 0."""
    v = check_array(v, "counts", self.mean.shape[0])
    return _powers(_standardise(v, self.mean, self.scale), self.degree)

  def predict(self, v: np.ndarray) -> np.ndarray:
    """(N, A) forces from (N, C) counts."""
    return self.features(v) @ self.coef + self.bias

  NAME, C_TAG = "linear", "LIN"

  @property
  def label(self) -> str:
    return "LS" if self.degree == 1 else "POLY"

  @property
  def tame(self) -> bool:
    """A plane is; each channel's cubic grows as a cube beyond the box."""
    return self.degree == 1

  @property
  def n_inputs(self) -> int:
    return len(self.mean)

  @property
  def n_outputs(self) -> int:
    return self.coef.shape[1]

  def leaves(self) -> tuple[dict, dict]:
    return ({f: getattr(self, f) for f in ("mean", "scale", "coef", "bias")},
            {"rank": self.rank, "degree": self.degree})

  @classmethod
  def from_leaves(cls, spec, arrays, children=None) -> "LinearFit":
    fit = cls(arrays["mean"], arrays["scale"], arrays["coef"], arrays["bias"],
              int(spec["rank"]), int(spec["degree"]))
    c, a = len(fit.mean), fit.bias.shape[0] if fit.bias.ndim == 1 else -1
    check_shapes("linear stage", arrays, {"mean": (c,), "scale": (c,),
                                          "coef": (c * fit.degree, a), "bias": (a,)})
    return fit

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> None:
    """Standardise, then each power of each channel times its row of coefficients."""
    inv = np.where(self.scale > 0, 1.0 / np.where(self.scale > 0, self.scale, 1.0), 0.0)
    mean, scale = em.array(f"{tag}_MEAN", self.mean), em.array(f"{tag}_INV_SCALE", inv)
    coef = em.array(f"{tag}_COEF", self.coef)  # (C * degree, A), row-major
    bias = em.array(f"{tag}_BIAS", self.bias)
    a, d = self.coef.shape[1], self.degree
    em.costs(macs=self.coef.size + c * (d - 1), stack=4 * c)
    em.code += [
        f"  {{ /* {'linear' if d == 1 else f'polynomial, degree {d}'} */",
        f"    float z[{c}];",
        f"    for (int i = 0; i < {c}; ++i) z[i] = (x[i] - {mean}[i]) * {scale}[i];",
        f"    for (int j = 0; j < {a}; ++j) {acc}[j] += {bias}[j];",
        f"    for (int i = 0; i < {c}; ++i) {{",
        "      float p = z[i];",
        f"      for (int d = 0; d < {d}; ++d) {{",
        f"        const float *row = &{coef}[(d * {c} + i) * {a}];",
        f"        for (int j = 0; j < {a}; ++j) {acc}[j] += row[j] * p;",
        "        p *= z[i];",
        "      }",
        "    }",
        "  }"]


def check_array(a, name: str, columns: int | None = None) -> np.ndarray:
  """A finite 2-D float64 array, or a ValueError naming `name` and what is wrong."""
  a = np.asarray(a)
  if a.dtype == np.float32:
    warnings.warn(f"{name} is float32: promoted to float64 (fits compute in float64)")
  if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
    raise errors.DataError(f"{name} must be numeric, got dtype {a.dtype}")
  a = a.astype(np.float64)
  if a.ndim != 2:
    raise errors.DataError(f"{name} must be 2-D (samples, channels), got shape {a.shape}")
  if columns is not None and a.shape[1] != columns:
    raise errors.DataError(f"{name} has {a.shape[1]} columns: the fit expects {columns}")
  if not np.isfinite(a).all():  # the whole array first: eight times faster than per row
    bad = ~np.isfinite(a).all(axis=1)
    raise errors.DataError(f"{name}: {bad.sum()} of {len(a)} rows hold NaN or inf "
                           f"(first at row {np.flatnonzero(bad)[0]}); drop them first")
  return a


def check_pair(v, f) -> tuple[np.ndarray, np.ndarray]:
  """Counts (N, C) and forces (N, A) checked as a training pair."""
  v, f = check_array(v, "counts"), check_array(f, "forces")
  if len(v) != len(f):
    raise errors.DataError(
        f"counts have {len(v)} samples but forces have {len(f)}: they must match")
  return v, f


def fit_linear(v: np.ndarray, f: np.ndarray, degree: int = 1, method: Method = Method.QR,
               rcond: float = 1e-10) -> LinearFit:
  """Least-squares fit of forces f (N, A) on counts v (N, C) plus a bias.

  Args:
    v: (N, C) counts (any real units).
    f: (N, A) forces, N.
    degree: 1 for the linear fit, 3 for the cubic pseudoinverse.
    method: pivoted QR, or SVD; both drop directions below `rcond` x the largest.
    rcond: relative cut-off on R's diagonal (QR) or the singular values (SVD).
  Warns when a channel is constant or the features are rank-deficient, naming what it dropped.
  """
  v, f = check_pair(v, f)
  if not (isinstance(degree, int) and 1 <= degree <= 5):
    raise errors.SettingError(f"degree={degree!r} is out of range: allowed integers 1..5")
  method = Method(method)
  n_par = v.shape[1] * degree + 1
  if len(v) <= n_par:
    raise errors.DataError(f"{len(v)} samples cannot fit {n_par} parameters per axis: "
                           f"need more than {n_par}")
  # statistics per channel along the contiguous rows of the transpose: numpy reduces those
  # about 3x faster than the short columns of v
  vt = np.ascontiguousarray(v.T)
  mean = vt.mean(axis=1)
  scale = vt.std(axis=1)
  # relative to the channel's own level: a constant channel's spread is rounding, ~1e-16 of
  # its mean (exactly 0 at mean 0), while a live channel may be in any units (1e-9 V...)
  dead = scale <= 1e-12 * np.abs(mean)
  if dead.any():
    warnings.warn(f"channels {np.flatnonzero(dead).tolist()} are constant: dropped from the fit")
  fit = LinearFit(mean, np.where(dead, 0.0, scale), np.zeros((0, 0)), np.zeros(0), 0, degree)
  keep = np.tile(~dead, degree)
  # the live channels' powers and the bias column, in the column-major order LAPACK's QR
  # works in (a row-major matrix would be transposed into a copy first)
  a = _powers(_standardise(v[:, ~dead], mean[~dead], scale[~dead]), degree, bias=True)
  sol, rank = _lstsq(a, f, method, rcond)
  if rank < a.shape[1]:
    warnings.warn(f"features are rank-deficient ({rank} of {a.shape[1]}): "
                  f"{a.shape[1] - rank} direction(s) dropped")
  coef = np.zeros((len(keep), f.shape[1]))
  coef[keep] = sol[:-1]
  return dataclasses.replace(fit, coef=coef, bias=sol[-1], rank=rank)


def _standardise(v: np.ndarray, mean: np.ndarray, scale: np.ndarray) -> np.ndarray:
  """(v - mean) / scale, 0 where scale is 0 (a dropped channel)."""
  if np.all(scale > 0):  # the usual case: no dropped channel, no mask to apply
    return (v - mean) / scale
  return np.divide(v - mean, scale, out=np.zeros_like(v), where=scale > 0)


def _powers(z: np.ndarray, degree: int, bias: bool = False) -> np.ndarray:
  """(N, C * degree [+ 1]) column-major [z, z^2, ... z^degree (, 1)]: products, not pow(),
  several times faster."""
  n, c = z.shape
  out = np.empty((n, c * degree + bias), order="F")
  out[:, :c] = z
  for k in range(1, degree):
    np.multiply(out[:, (k - 1) * c:k * c], z, out=out[:, k * c:(k + 1) * c])
  if bias:
    out[:, -1] = 1.0
  return out


def _lstsq(a: np.ndarray, f: np.ndarray, method: Method, rcond: float):
  """Solution of a @ x ~ f (QR: basic, SVD: minimum-norm; equal at full rank) and its rank."""
  if method is Method.QR:
    # LAPACK's pivoted QR, then Q^T f by the reflectors themselves (dormqr): forming Q and
    # multiplying took a third longer on the shell's 97526 x 25 cubic features. `a` is this
    # module's own finite column-major feature matrix: factored in place, no copy.
    qr, perm, tau, _, info = scipy.linalg.lapack.dgeqp3(a, overwrite_a=True)
    if info != 0:
      raise RuntimeError(f"LAPACK dgeqp3 failed (info={info})")
    n = a.shape[1]
    c = np.asfortranarray(f, dtype=np.float64)
    lwork = int(scipy.linalg.lapack.dormqr("L", "T", qr, tau, c, -1)[1][0])
    qtf, _, info = scipy.linalg.lapack.dormqr("L", "T", qr, tau, c, lwork)
    if info != 0:
      raise RuntimeError(f"LAPACK dormqr failed (info={info})")
    r = np.triu(qr[:n])
    d = np.abs(np.diag(r))
    rank = int(np.sum(d > rcond * d[0]))
    sol = np.zeros((n, f.shape[1]))
    sol[perm[:rank] - 1] = scipy.linalg.solve_triangular(r[:rank, :rank], qtf[:rank])
    return sol, rank
  u, s, vt = scipy.linalg.svd(a, full_matrices=False)
  rank = int(np.sum(s > rcond * s[0]))
  return vt[:rank].T @ ((u[:, :rank].T @ f) / s[:rank, None]), rank
