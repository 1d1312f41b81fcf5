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
import json
import pathlib
from typing import Optional

import numpy as np

from calibrate import linear, mlp


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
    """Writes the arrays and settings to one .npz file."""
    arrays = {}
    if self.linear is not None:
      for f in ("mean", "scale", "coef", "bias"):
        arrays[f"linear_{f}"] = getattr(self.linear, f)
    if self.net is not None:
      arrays.update(net_w1=self.net.w1, net_w2=self.net.w2, net_x_lo=self.net.x_scale.lo,
                    net_x_hi=self.net.x_scale.hi, net_y_lo=self.net.y_scale.lo,
                    net_y_hi=self.net.y_scale.hi)
    meta = {"kind": self.kind.value, "format": 1}
    if self.linear is not None:
      meta.update(rank=self.linear.rank, degree=self.linear.degree)
    np.savez(pathlib.Path(path), meta=json.dumps(meta), **arrays)

  @staticmethod
  def load(path) -> "Estimator":
    with np.load(pathlib.Path(path)) as z:
      meta = json.loads(str(z["meta"]))
      lin = net = None
      if "linear_coef" in z:
        lin = linear.LinearFit(z["linear_mean"], z["linear_scale"], z["linear_coef"],
                               z["linear_bias"], meta["rank"], meta["degree"])
      if "net_w1" in z:
        net = mlp.MLP(z["net_w1"], z["net_w2"], mlp.MinMax(z["net_x_lo"], z["net_x_hi"]),
                      mlp.MinMax(z["net_y_lo"], z["net_y_hi"]))
    return Estimator(Kind(meta["kind"]), lin, net)


def split_validation(n: int, fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
  """Random (train, validation) indices, MATLAB `dividerand` style, from one integer seed."""
  if not 0 < fraction < 1:
    raise ValueError(f"validation fraction {fraction!r} is out of range: allowed (0, 1)")
  idx = np.random.default_rng(np.random.SeedSequence([seed, 1])).permutation(n)
  n_val = max(1, int(round(fraction * n)))
  return np.sort(idx[n_val:]), np.sort(idx[:n_val])


def fit(kind: Kind, counts: np.ndarray, forces: np.ndarray, *,
        linear_fit: Optional[linear.LinearFit] = None, config: mlp.LMConfig = mlp.LMConfig(),
        val_fraction: float = 0.15, seed: int = 0, progress=None,
        degree: int = 3, snapshots: tuple[int, ...] = ()) -> Estimator:
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
  tr, va = split_validation(len(inputs), val_fraction, seed)
  res = mlp.train(inputs[tr], targets[tr], inputs[va], targets[va], config, seed, progress,
                  snapshots=snapshots)
  return Estimator(kind, lin, res.net, res)


def at_epoch_cap(est: Estimator, cap: int) -> Estimator:
  """The estimator that training `est` with `epochs=cap` would have returned (its fit must
  have been asked for that cap in `snapshots`)."""
  net, _ = est.training.snapshots[cap]
  return dataclasses.replace(est, net=net)
