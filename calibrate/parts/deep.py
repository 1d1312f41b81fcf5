"""A multilayer perceptron of one or two hidden layers (ReLU or tanh units) trained by AdamW,
what users reach for in a few lines (scikit-learn's `MLPRegressor(64, 64)`, early stopping).

The paper's network (`calibrate.parts.mlp`: one layer of 10, Levenberg-Marquardt) forms
J^T J, whose size grows with the square of the weights: at 64x64 (4,800 weights) that is
23 M entries per step. A first-order method does not: AdamW (Loshchilov & Hutter 2019,
decoupled weight decay) on minibatches drawn with replacement, its held-out error checked
every `DeepConfig.steps` steps. Where the data have held-out groups, `fold_curve` trains one
network per fold in step and reads the folds' mean held-out curve: its lowest sets how many
checks the final network trains on every sample (`DeepConfig.checks`). Without folds it
stops early on a validation hold-out, the weights of the best check kept. Inputs and outputs
are standardised (mean, standard deviation).

Everything is float64 (JAX's 64-bit types on for the duration of a call). The training
data are padded to the next power of two and the batches drawn from the rows in use, so
one compiled step serves every fold of similar size.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from calibrate.parts import linear
from calibrate.parts.base import Part, check_shapes
from calibrate.parts.mlp import Stop, TrainResult, float64
from util import errors

# the layer sizes grouped cross-validation chooses among (`methods.choose`): one or two
# hidden layers of 16 to 128 units, scikit-learn's default (100,) and the (64, 64) users write
GRID = ((16,), (64,), (32, 32), (64, 64), (128, 128))
ACTIVATIONS = ("relu", "tanh")


@dataclasses.dataclass(frozen=True)
class DeepConfig:
  """AdamW settings; the defaults are scikit-learn `MLPRegressor`'s where it has one.

  Attributes:
    layers: hidden units per layer (one or two layers, 1 to 512 units each).
    learning_rate: Adam's step size (1e-3, as scikit-learn's and Kingma & Ba's).
    weight_decay: decoupled decay of the weights per unit learning rate (1e-4, as
      scikit-learn's alpha); biases are not decayed.
    batch: samples per step (256; scikit-learn's min(200, N)).
    steps: steps between held-out checks (an "epoch" here; 50).
    epochs: the cap on checks (300: 15,000 steps).
    patience: checks without a better held-out error that stop training (10, scikit-learn's
      n_iter_no_change), on the validation hold-out or on the folds' mean curve.
    checks: 0 stops early on the validation hold-out; N trains exactly N checks on every
      sample and keeps the last weights (`calibrate.methods` sets it from the held-out
      groups' mean curve, `fold_curve`).
    activation: the hidden units' function: "tanh" (smooth, saturating) or "relu"
      (max(0, v), scikit-learn's default: planes by region, continued as planes past the
      data); `calibrate.estimators.fit` chooses between them on held-out groups.
  """
  layers: tuple = (64, 64)
  learning_rate: float = 1e-3
  weight_decay: float = 1e-4
  batch: int = 256
  steps: int = 50
  epochs: int = 300
  patience: int = 10
  activation: str = "tanh"
  checks: int = 0

  def validate(self) -> None:
    """Raises SettingError naming the first setting out of range."""
    if self.activation not in ACTIVATIONS:
      raise errors.SettingError(f"activation={self.activation!r} is unknown: allowed "
                                f"{', '.join(repr(a) for a in ACTIVATIONS)}")
    if not (1 <= len(self.layers) <= 2 and all(isinstance(w, (int, np.integer)) and
                                               1 <= w <= 512 for w in self.layers)):
      raise errors.SettingError(f"layers={self.layers!r} is out of range: one or two hidden "
                                f"layers of 1 to 512 units")
    for name, lo, hi in (("learning_rate", 1e-6, 1.0), ("weight_decay", 0.0, 1.0)):
      value = getattr(self, name)
      if not (np.isfinite(value) and lo <= value <= hi):
        raise errors.SettingError(f"{name}={value!r} is out of range: allowed [{lo:g}, {hi:g}]")
    for name, hi in (("batch", 65536), ("steps", 100000), ("epochs", 100000),
                     ("patience", 100000)):
      value = getattr(self, name)
      if not (isinstance(value, (int, np.integer)) and 1 <= value <= hi):
        raise errors.SettingError(f"{name}={value!r} is out of range: allowed integers 1 to "
                                  f"{hi}")
    if not (isinstance(self.checks, (int, np.integer)) and 0 <= self.checks <= self.epochs):
      raise errors.SettingError(f"checks={self.checks!r} is out of range: allowed integers 0 "
                                f"to epochs ({self.epochs})")


@dataclasses.dataclass(frozen=True)
class Deep(Part):
  """A fitted perceptron: (weights (out, in), biases (out,)) per layer, `activation` between
  them, and the inputs' and outputs' standardisation (mean, sd per column)."""
  weights: tuple
  biases: tuple
  x_mean: np.ndarray
  x_sd: np.ndarray
  y_mean: np.ndarray
  y_sd: np.ndarray
  activation: str = "tanh"  # files written before 2026-12-03 hold tanh networks

  NAME, C_TAG, LABEL = "deep", "MLP", "MLP"
  RESIDUAL_LABEL = "MLP"  # LS plus this network on its residual

  @float64
  def predict(self, x: np.ndarray) -> np.ndarray:
    x = linear.check_array(x, "inputs", self.n_inputs)
    s = _forward(tuple(zip(self.weights, self.biases)), jnp.asarray((x - self.x_mean) / self.x_sd),
                 self.activation)
    return np.asarray(s) * self.y_sd + self.y_mean

  @property
  def n_inputs(self) -> int:
    return self.weights[0].shape[1]

  @property
  def n_outputs(self) -> int:
    return self.weights[-1].shape[0]

  @property
  def tame(self) -> bool:
    return False

  def without_outputs(self, outputs: np.ndarray) -> "Deep":
    """The network with its contribution removed on `outputs` (bool (A,))."""
    return dataclasses.replace(self, y_sd=np.where(outputs, 0.0, self.y_sd),
                               y_mean=np.where(outputs, 0.0, self.y_mean))

  def leaves(self) -> tuple[dict, dict]:
    arrays = {"x_mean": self.x_mean, "x_sd": self.x_sd, "y_mean": self.y_mean,
              "y_sd": self.y_sd}
    for k, (w, b) in enumerate(zip(self.weights, self.biases)):
      arrays[f"w{k}"], arrays[f"b{k}"] = w, b
    return arrays, {"layers": len(self.weights), "activation": self.activation}

  @classmethod
  def from_leaves(cls, spec, arrays, children=None) -> "Deep":
    n = int(spec["layers"])
    if not 2 <= n <= 3 or any(np.ndim(arrays.get(f"w{k}")) != 2 for k in range(n)):
      raise ValueError("its layers are not 2 or 3 weight matrices")
    shapes = [np.shape(arrays[f"w{k}"]) for k in range(n)]
    c, a = shapes[0][1], shapes[-1][0]
    want = {"x_mean": (c,), "x_sd": (c,), "y_mean": (a,), "y_sd": (a,)}
    for k in range(n):
      want[f"b{k}"] = (shapes[k][0],)
      if k:
        want[f"w{k}"] = (shapes[k][0], shapes[k - 1][0])
    check_shapes("perceptron", arrays, want)
    activation = spec.get("activation", "tanh")
    if activation not in ACTIVATIONS:
      raise ValueError(f"its activation {activation!r} is not one of {ACTIVATIONS}")
    return cls(tuple(arrays[f"w{k}"] for k in range(n)),
               tuple(arrays[f"b{k}"] for k in range(n)), arrays["x_mean"], arrays["x_sd"],
               arrays["y_mean"], arrays["y_sd"], activation)

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> None:
    """Standardisation, the hidden layers (tanh or ReLU), the linear output, added to acc[]."""
    c = self.n_inputs
    sizes = [c] + [w.shape[0] for w in self.weights]
    xm, xi = em.array(f"{tag}_XMEAN", self.x_mean), em.array(f"{tag}_XINV", 1.0 / self.x_sd)
    ym, ys = em.array(f"{tag}_YMEAN", self.y_mean), em.array(f"{tag}_YSD", self.y_sd)
    hidden = sizes[1:-1]
    em.costs(macs=sum(m * n + n for m, n in zip(sizes[:-1], sizes[1:])) + c + sizes[-1],
             tanh=sum(hidden) if self.activation == "tanh" else 0,
             stack=4 * (c + 2 * max(hidden)))
    unit = {"tanh": "tanhf(v)", "relu": "v > 0.0f ? v : 0.0f"}[self.activation]
    code = [f"  {{ /* perceptron: standardise, {self.activation} layers, linear output */",
            f"    float h0[{max(sizes[:-1])}], h1[{max(sizes[:-1])}];",
            f"    for (int i = 0; i < {c}; ++i) h0[i] = (x[i] - {xm}[i]) * {xi}[i];"]
    src, dst = "h0", "h1"
    for k, (m, n) in enumerate(zip(sizes[:-1], sizes[1:])):
      w, b = em.array(f"{tag}_W{k}", self.weights[k]), em.array(f"{tag}_B{k}", self.biases[k])
      last = k == len(self.weights) - 1
      code += [f"    for (int j = 0; j < {n}; ++j) {{",
               f"      float v = {b}[j];",
               f"      for (int i = 0; i < {m}; ++i) v += {w}[j * {m} + i] * {src}[i];",
               f"      {acc}[j] += v * {ys}[j] + {ym}[j];" if last else
               f"      {dst}[j] = {unit};",
               "    }"]
      src, dst = dst, src
    em.code += code + ["  }"]


def _forward(params, x, activation: str):
  unit = jax.nn.relu if activation == "relu" else jnp.tanh
  h = x
  for w, b in params[:-1]:
    h = unit(h @ w.T + b)
  w, b = params[-1]
  return h @ w.T + b


def _init(key, sizes):
  """Glorot-uniform weights (scikit-learn's for tanh and ReLU alike), zero biases."""
  params = []
  for m, n in zip(sizes[:-1], sizes[1:]):
    key, k = jax.random.split(key)
    limit = np.sqrt(6.0 / (m + n))
    params.append((jax.random.uniform(k, (n, m), jnp.float64, -limit, limit),
                   jnp.zeros(n, jnp.float64)))
  return tuple(params)


B1, B2, EPS = 0.9, 0.999, 1e-8  # Adam's moment decays and floor (Kingma & Ba)


def _epoch_fn(config: DeepConfig):
  """One jitted check interval: `steps` AdamW steps on batches drawn from the first n rows."""
  return _compiled_epoch(config.learning_rate, config.weight_decay, config.batch, config.steps,
                         config.activation)


@functools.lru_cache(maxsize=None)
def _compiled_epoch(lr: float, wd: float, batch: int, steps: int, activation: str):
  def loss(params, xb, yb):
    return jnp.mean((_forward(params, xb, activation) - yb) ** 2)

  grad = jax.grad(loss)

  def epoch(state, key, x, y, n):
    def step(carry, k):
      params, m, v, t = carry
      idx = jax.random.randint(k, (batch,), 0, n)
      g = grad(params, x[idx], y[idx])
      t = t + 1
      m = jax.tree_util.tree_map(lambda a, b: B1 * a + (1 - B1) * b, m, g)
      v = jax.tree_util.tree_map(lambda a, b: B2 * a + (1 - B2) * b * b, v, g)
      c1, c2 = 1 - B1 ** t, 1 - B2 ** t
      params = tuple(
          (w - lr * ((mw / c1) / (jnp.sqrt(vw / c2) + EPS) + wd * w),
           b - lr * (mb / c1) / (jnp.sqrt(vb / c2) + EPS))
          for (w, b), (mw, mb), (vw, vb) in zip(params, m, v))
      return (params, m, v, t), None
    out, _ = jax.lax.scan(step, state, jax.random.split(key, steps))
    return out

  return jax.jit(epoch)


@functools.partial(jax.jit, static_argnums=(4,))
def _mse(params, x, y, mask, activation: str):
  """(A,) the mean squared error per output over the rows where `mask` is 1."""
  return jnp.sum(((_forward(params, x, activation) - y) ** 2) * mask[:, None], axis=0) / \
      jnp.sum(mask)


def _padded(a: np.ndarray) -> np.ndarray:
  """`a` with zero rows to the next power of two (one compiled step per size class)."""
  size = 1 << max(int(np.ceil(np.log2(max(len(a), 1)))), 0)
  return np.vstack([a, np.zeros((size - len(a), a.shape[1]))])


@dataclasses.dataclass
class _Run:
  """One network's training in progress: its standardisation, padded data, AdamW state and
  the keys of its checks (the same seed draws the same ones, however long it runs)."""
  x_mean: np.ndarray
  x_sd: np.ndarray
  y_mean: np.ndarray
  y_sd: np.ndarray
  xs: np.ndarray
  ys: np.ndarray
  n: int
  state: tuple
  keys: jax.Array

  @classmethod
  def start(cls, x, y, config: DeepConfig, seed: int) -> "_Run":
    x_mean, x_sd = x.mean(axis=0), x.std(axis=0)
    y_mean, y_sd = y.mean(axis=0), y.std(axis=0)
    x_sd, y_sd = np.where(x_sd > 0, x_sd, 1.0), np.where(y_sd > 0, y_sd, 1.0)
    key = jax.random.PRNGKey(seed % 2 ** 32)
    key, k0 = jax.random.split(key)
    params = _init(k0, (x.shape[1],) + tuple(int(w) for w in config.layers) + (y.shape[1],))
    zeros = jax.tree_util.tree_map(jnp.zeros_like, params)
    return cls(x_mean, x_sd, y_mean, y_sd, _padded((x - x_mean) / x_sd),
               _padded((y - y_mean) / y_sd), len(x),
               (params, zeros, zeros, jnp.zeros((), jnp.float64)),
               jax.random.split(key, config.epochs))

  def check(self, k: int, epoch) -> None:
    """Runs check k (0-based): `steps` AdamW steps."""
    self.state = epoch(self.state, self.keys[k], self.xs, self.ys, self.n)

  def held_out(self, x_val, y_val) -> tuple:
    """(held-out inputs, outputs, row mask), padded and standardised: for `mse`."""
    xv = _padded((x_val - self.x_mean) / self.x_sd)
    mask = np.zeros(len(xv))
    mask[:len(x_val)] = 1.0
    return xv, _padded((y_val - self.y_mean) / self.y_sd), mask

  def mse(self, params, held: tuple, activation: str) -> np.ndarray:
    """(A,) held-out MSE per output, in standardised units."""
    out = np.asarray(_mse(params, *held, activation))
    if not np.isfinite(out).all():
      raise errors.DataError("the perceptron's training diverged (held-out error not finite): "
                             "lower its learning rate")
    return out

  def net(self, params, activation: str) -> Deep:
    return Deep(tuple(np.asarray(w) for w, _ in params), tuple(np.asarray(b) for _, b in params),
                self.x_mean, self.x_sd, self.y_mean, self.y_sd, activation)


@dataclasses.dataclass(frozen=True)
class Curve:
  """The folds' mean held-out curve (`fold_curve`).

  Attributes:
    checks: the check of its lowest score (1-based), the length to train on every sample.
    mse: (K + 1, A) held-out MSE per output over every fold's held-out samples, in output
      units, after 0..K checks (row 0 the untrained networks').
    floor: (A,) the held-out MSE of predicting zero (LS alone, where the targets are its
      residual): an output's score never counts more than this (inf where not floored).
    score: (K + 1,) sum over the outputs of min(mse, floor) x `scale`.
    runs: one TrainResult per fold, each holding its network at `checks`.
  """
  checks: int
  mse: np.ndarray
  floor: np.ndarray
  score: np.ndarray
  runs: tuple


@float64
def fold_curve(folds, config: DeepConfig = DeepConfig(), seed: int = 0, scale=None,
               floored: bool = True) -> Curve:
  """Trains one network per fold, all in step from the same seed, on `folds` ((x_train,
  y_train, x_held, y_held) each), and stops when the folds' mean held-out score has not
  improved in `patience` checks (or at `epochs`). The score sums each output's held-out MSE
  times `scale` (A,) (None: over the first fold's training variance, the network's own
  standardisation), with `floored` counting no output above its floor: an output the
  networks cannot improve on is left to LS (`calibrate.select.ls_only`), so its rise does
  not stop the others' training. Each fold's network at the lowest score is what training
  that fold with `checks` set to it gives (the same seed draws the same batches). One fold
  unfloored is early stopping on a validation hold-out (`train`)."""
  config.validate()
  folds = [(*linear.check_pair(xt, yt), np.asarray(xv, float), np.asarray(yv, float))
           for xt, yt, xv, yv in folds]
  if not folds or any(len(xv) == 0 for _, _, xv, _ in folds):
    raise errors.DataError("the perceptron's held-out curve needs held-out samples in every "
                           "fold")
  epoch = _epoch_fn(config)
  runs = [_Run.start(xt, yt, config, seed) for xt, yt, _, _ in folds]
  held = [r.held_out(xv, yv) for r, (_, _, xv, yv) in zip(runs, folds)]
  total = sum(len(xv) for _, _, xv, _ in folds)
  scale = 1.0 / runs[0].y_sd ** 2 if scale is None else np.asarray(scale, float)
  floor = sum(np.sum(yv ** 2, axis=0) for _, _, _, yv in folds) / total if floored else \
      np.full(len(scale), np.inf)

  def mean_mse():
    return sum(r.mse(r.state[0], h, config.activation) * r.y_sd ** 2 * len(xv)
               for r, h, (_, _, xv, _) in zip(runs, held, folds)) / total

  curve = [mean_mse()]
  t0 = time.perf_counter()
  for r in runs:
    r.check(0, epoch)  # the first compiles (folds of one size class share it)
  compile_s = time.perf_counter() - t0
  curve.append(mean_mse())
  score = [float(np.sum(np.minimum(c, floor) * scale)) for c in curve]
  best_k, best = 1, [r.state[0] for r in runs]
  t0 = time.perf_counter()
  for k in range(1, config.epochs):
    if k - best_k >= config.patience:
      break
    for r in runs:
      r.check(k, epoch)
    curve.append(mean_mse())
    score.append(float(np.sum(np.minimum(curve[-1], floor) * scale)))
    if score[-1] < score[best_k]:
      best_k, best = k + 1, [r.state[0] for r in runs]
  seconds = (time.perf_counter() - t0) / len(runs)
  mse = np.array(curve)
  stop = Stop.VALIDATION if len(curve) - 1 < config.epochs else Stop.MAX_EPOCHS
  return Curve(best_k, mse, floor, np.array(score), tuple(
      TrainResult(r.net(p, config.activation), len(curve) - 1, stop,
                  np.full(len(curve), np.nan), np.mean(mse, axis=1), seconds,
                  compile_s / len(runs), best_k) for r, p in zip(runs, best)))


@float64
def train(x: np.ndarray, y: np.ndarray, x_val: np.ndarray, y_val: np.ndarray,
          config: DeepConfig = DeepConfig(), seed: int = 0) -> TrainResult:
  """Trains on (x, y) (N, C), (N, A). With `config.checks` 0 it stops on the held-out
  (x_val, y_val), keeping the weights of the check with the lowest held-out MSE; with N it
  trains exactly N checks and keeps the last weights, (x_val, y_val) unused (may be empty)."""
  config.validate()
  x, y = linear.check_pair(x, y)
  if not config.checks:  # early stopping: one fold's held-out curve, no output floored
    if len(x_val) == 0:
      raise errors.DataError("the perceptron's early stopping needs held-out samples")
    return fold_curve([(x, y, x_val, y_val)], config, seed, floored=False).runs[0]
  run = _Run.start(x, y, config, seed)
  epoch = _epoch_fn(config)
  t0 = time.perf_counter()
  run.check(0, epoch)  # compiles
  compile_s = time.perf_counter() - t0
  t0 = time.perf_counter()
  for k in range(1, config.checks):
    run.check(k, epoch)
  if not all(np.isfinite(np.asarray(a)).all() for a in jax.tree_util.tree_leaves(run.state[0])):
    raise errors.DataError("the perceptron's training diverged (weights not finite): lower "
                           "its learning rate")
  return TrainResult(run.net(run.state[0], config.activation), config.checks,
                     Stop.MAX_EPOCHS, np.full(config.checks + 1, np.nan),
                     np.full(config.checks + 1, np.nan), time.perf_counter() - t0,
                     compile_s, config.checks)
