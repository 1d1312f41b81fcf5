"""Force estimators of the LSANN paper as plain data: fit, predict, save, load.

* LS: linear least squares from the six die counts (paper Sec. III-B).
* POLY: the cubic pseudoinverse (force-sensing-shell paper), same numerics.
* LSANN: LS, then the network fitted to the residual F - F_LS from the six counts (paper
  Sec. III-C: "the input is the array of voltage signals"; Eqn 8 sums the two).
* NN: the same network fitted to F from the six counts.
"""

from __future__ import annotations

import dataclasses
import enum
import pathlib
import zipfile
from typing import Optional

import numpy as np

from calibrate import linear, mlp
from models import errors, files


class Kind(enum.Enum):
  LS = "LS"
  POLY = "POLY"
  LSANN = "LSANN"
  NN = "NN"


@dataclasses.dataclass(frozen=True)
class Estimator:
  """A fitted estimator: the linear stage and/or the network, and how it was trained."""
  kind: Kind
  linear: Optional[linear.LinearFit] = None
  net: Optional[mlp.MLP] = None
  training: Optional[mlp.TrainResult] = None

  def predict(self, counts: np.ndarray) -> np.ndarray:
    """(N, A) forces, N, from (N, C) counts."""
    if self.kind is Kind.NN:
      return self.net.predict(counts)
    f = self.linear.predict(counts)
    return f + self.net.predict(counts) if self.kind is Kind.LSANN else f

  def save(self, path) -> None:
    """Writes the arrays and settings to one .npz file, atomically, with the format tag and
    a SHA-256 of the arrays that `load` checks."""
    arrays = {}
    if self.linear is not None:
      for f in ("mean", "scale", "coef", "bias"):
        arrays[f"linear_{f}"] = getattr(self.linear, f)
    if self.net is not None:
      arrays.update(net_w1=self.net.w1, net_w2=self.net.w2, net_x_lo=self.net.x_scale.lo,
                    net_x_hi=self.net.x_scale.hi, net_y_lo=self.net.y_scale.lo,
                    net_y_hi=self.net.y_scale.hi)
    meta = {"kind": self.kind.value, "format": FORMAT, "version": VERSION,
            "sha256": files.array_digest(arrays)}
    if self.linear is not None:
      meta.update(rank=self.linear.rank, degree=self.linear.degree)
    files.atomic_write(pathlib.Path(path),
                       lambda f: np.savez(f, meta=files.json_text(meta), **arrays))

  @staticmethod
  def load(path) -> "Estimator":
    """Reads a file `save` wrote, checked: format tag and version, checksum, shapes and
    finiteness of every array.

    Raises:
      errors.DataError naming the file and what is wrong with it.
    """
    path = pathlib.Path(path)
    try:
      with np.load(path) as z:
        meta = files.from_json(str(z["meta"]))
        arrays = {k: z[k] for k in z.files if k != "meta"}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
      raise errors.DataError(f"estimator {path}: cannot be read ({err})") from None
    files.check_header(meta, path, "estimator", FORMAT, VERSION, files.array_digest(arrays))
    bad = [k for k, a in arrays.items() if not np.isfinite(a).all()]
    if bad:
      raise errors.DataError(f"estimator {path}: {', '.join(bad)} hold NaN or inf")
    try:
      kind = Kind(meta["kind"])
      lin = net = None
      if "linear_coef" in arrays:
        lin = linear.LinearFit(arrays["linear_mean"], arrays["linear_scale"],
                               arrays["linear_coef"], arrays["linear_bias"], int(meta["rank"]),
                               int(meta["degree"]))
        c = len(lin.mean)
        if lin.scale.shape != (c,) or lin.coef.shape[0] != c * lin.degree or \
           lin.bias.shape != lin.coef.shape[1:]:
          raise ValueError("the linear stage's arrays do not fit together")
      if "net_w1" in arrays:
        net = mlp.MLP(arrays["net_w1"], arrays["net_w2"],
                      mlp.MinMax(arrays["net_x_lo"], arrays["net_x_hi"]),
                      mlp.MinMax(arrays["net_y_lo"], arrays["net_y_hi"]))
        h, inputs = net.w1.shape
        if net.w2.shape[1] != h + 1 or net.x_scale.lo.shape != (inputs - 1,) or \
           net.y_scale.lo.shape != (net.w2.shape[0],):
          raise ValueError("the network's arrays do not fit together")
      if (kind is not Kind.NN and lin is None) or (kind in (Kind.NN, Kind.LSANN) and net is None):
        raise ValueError(f"a {kind.value} estimator needs its "
                         f"{'linear stage' if lin is None else 'network'}")
    except (KeyError, ValueError, TypeError) as err:
      raise errors.DataError(f"estimator {path}: {err}") from None
    return Estimator(kind, lin, net)


FORMAT = "testbench-estimator"
VERSION = 2  # 1: no format tag or checksum


def split_validation(n: int, fraction: float, seed: int, block: Optional[int] = None
                     ) -> tuple[np.ndarray, np.ndarray]:
  """Random (train, validation) indices from one integer seed.

  block=None draws single samples (MATLAB `dividerand`, the paper's): at 1 kHz every
  validation sample then sits beside training samples, and early stopping rarely fires.
  With `block` (samples), whole contiguous blocks of that length are held out instead.
  """
  if not 0 < fraction < 1:
    raise errors.SettingError(f"validation fraction {fraction!r} is out of range: allowed (0, 1)")
  rng = np.random.default_rng(np.random.SeedSequence([seed, 1]))
  if block is None:
    idx = rng.permutation(n)
    n_val = max(1, int(round(fraction * n)))
    return np.sort(idx[n_val:]), np.sort(idx[:n_val])
  if not 1 <= block <= n // 2:
    raise errors.SettingError(f"validation block {block!r} is out of range: allowed 1 to "
                              f"{n // 2} samples (two blocks at least)")
  starts = np.arange(0, n, block)
  n_val = max(1, int(round(fraction * len(starts))))
  held = np.zeros(n, bool)
  for b in rng.permutation(len(starts))[:n_val]:
    held[starts[b]:starts[b] + block] = True
  return np.flatnonzero(~held), np.flatnonzero(held)


def fit(kind: Kind, counts: np.ndarray, forces: np.ndarray, *,
        linear_fit: Optional[linear.LinearFit] = None, config: mlp.LMConfig = mlp.LMConfig(),
        val_fraction: float = 0.15, seed: int = 0, progress=None,
        degree: int = 3, snapshots: tuple[int, ...] = (),
        val_block: Optional[int] = None) -> Estimator:
  """Fits an estimator of the given kind.

  Args:
    kind: which estimator.
    counts, forces: (N, C) counts and (N, A) forces of the training data.
    linear_fit: for LSANN, the LS stage fitted beforehand (the paper fits it on the Z/X/Y
      strokes, the network on other paths); fitted on (counts, forces) when None.
    config: network training settings.  val_fraction: share held out for validation stops.
    seed: integer for the validation split and the network's start point.
    degree: the polynomial degree of POLY (the shell paper's cubic: 3).
    snapshots: epoch caps to keep the best net at (`at_epoch_cap`).
    val_block: hold out contiguous blocks of this many samples for validation instead of
      single samples (`split_validation`).
  """
  kind = Kind(kind)
  counts, forces = linear.check_pair(counts, forces)
  if kind in (Kind.LS, Kind.POLY):
    return Estimator(kind, linear.fit_linear(counts, forces,
                                             degree=degree if kind is Kind.POLY else 1))
  lin = None
  inputs, targets = counts, forces
  if kind is Kind.LSANN:
    lin = linear_fit or linear.fit_linear(counts, forces)
    targets = forces - lin.predict(counts)
  tr, va = split_validation(len(inputs), val_fraction, seed, val_block)
  res = mlp.train(inputs[tr], targets[tr], inputs[va], targets[va], config, seed, progress,
                  snapshots=snapshots)
  return Estimator(kind, lin, res.net, res)


def at_epoch_cap(est: Estimator, cap: int) -> Estimator:
  """The estimator that training `est` with `epochs=cap` would have returned (its fit must
  have been asked for that cap in `snapshots`)."""
  net, _ = est.training.snapshots[cap]
  return dataclasses.replace(est, net=net)
