"""One-hidden-layer tanh network trained by Levenberg-Marquardt in JAX (MATLAB `trainlm` style).

The network maps inputs x (N, D) to outputs y (N, O) through
  y = W2 @ [tanh(W1 @ [x; 1]); 1],
with inputs and outputs scaled to [-1, 1] (MATLAB `mapminmax`). Parameters are one vector
theta = [W1 (H, D+1) row-major, W2 (O, H+1) row-major], P = H (D+1) + O (H+1).

`normal_equations` forms J^T J and J^T e from the layer structure: with A = [x, 1],
g = 1 - h^2 and Z = g (x) A (N, H (D+1)), the W1 block is (Z^T Z) * kron(W2^T W2, 1), the
cross block is Z^T [h, 1] scaled by W2, and the W2 block is kron(I_O, [h,1]^T [h,1]); no
(N O, P) Jacobian is materialised. Everything is float64: the public entry points (`train`,
`MLP.predict`, `nguyen_widrow`) switch JAX's 64-bit types on for their own duration
(`float64`); importing this module changes no global setting. Callers of the building blocks
(`normal_equations`, `residuals`) wrap them in `jax.enable_x64(True)` themselves.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import time
from typing import Callable, Optional

import jax
import jax.numpy as jnp
import numpy as np

from calibrate.parts import linear
from calibrate.parts.base import Part, check_shapes
from util import errors



def float64(fn):
  """Runs `fn` with JAX's 64-bit types on, scoped to the call."""
  @functools.wraps(fn)
  def scoped(*args, **kwargs):
    with jax.enable_x64(True):
      return fn(*args, **kwargs)
  return scoped


class Stop(enum.Enum):
  """Why training ended (MATLAB trainlm's stopping rules)."""
  MAX_EPOCHS = "maximum epochs reached"
  VALIDATION = "validation error rose max_fail times in a row"
  MIN_GRADIENT = "gradient below min_grad"
  MU_MAX = "mu above mu_max"
  GOAL = "training MSE reached goal"


@dataclasses.dataclass(frozen=True)
class LMConfig:
  """Levenberg-Marquardt settings; defaults are MATLAB trainlm's.

  Attributes:
    hidden: hidden tanh units (paper: 10).
    mu, mu_dec, mu_inc, mu_max: damping start, factor on success, on failure, and limit.
    max_fail: validation failures in a row that stop training.
    min_grad: stop when the gradient norm of the (scaled) MSE falls below this.
    epochs: maximum accepted-or-failed LM epochs.
    goal: stop when the scaled training MSE falls to this.
    backend: "own" (this module) or "jaxopt" (jaxopt.LevenbergMarquardt, same problem and
      start, one LM iteration per epoch so validation stopping applies alike).
    damping: how the own backend moves mu. "trainlm" (MATLAB's, the paper's): x mu_dec on
      success, x mu_inc on failure. "nielsen": the gain-ratio rule of Madsen, Nielsen &
      Tingleff (2004, Sec. 3.2; jaxopt's too): on success mu x max(1/3, 1 - (2 rho - 1)^3)
      with rho the actual over the predicted decrease, on failure x nu, nu doubling; it needs
      fewer epochs near a minimum (`lm_solvers` measures both).
    weight_decay: lambda of the penalty lambda |theta|^2 added to the scaled sum of squared
      errors (own backend): a regularised network for data with few distinct load states,
      where an unpenalised one interpolates wildly between them. 0: MATLAB trainlm's.
  """
  hidden: int = 10
  mu: float = 1e-3
  mu_dec: float = 0.1
  mu_inc: float = 10.0
  mu_max: float = 1e10
  max_fail: int = 6
  min_grad: float = 1e-7
  epochs: int = 1000
  goal: float = 0.0
  backend: str = "own"
  damping: str = "trainlm"
  weight_decay: float = 0.0

  def validate(self) -> None:
    if not (isinstance(self.hidden, (int, np.integer)) and 1 <= self.hidden <= 1000):
      raise errors.SettingError(
          f"hidden={self.hidden!r} is out of range: allowed integers 1..1000")
    for name in ("mu", "mu_max", "min_grad"):
      if not getattr(self, name) > 0:
        raise errors.SettingError(f"{name}={getattr(self, name)!r} must be > 0")
    if not 0 < self.mu_dec < 1 < self.mu_inc:
      raise errors.SettingError(
          f"need 0 < mu_dec < 1 < mu_inc, got {self.mu_dec}, {self.mu_inc}")
    if not (isinstance(self.epochs, (int, np.integer)) and self.epochs >= 1):
      raise errors.SettingError(f"epochs={self.epochs!r} must be an integer >= 1")
    if not (isinstance(self.max_fail, (int, np.integer)) and self.max_fail >= 1):
      raise errors.SettingError(f"max_fail={self.max_fail!r} must be an integer >= 1")
    if self.backend not in ("own", "jaxopt"):
      raise errors.SettingError(
          f"backend={self.backend!r} is unknown: allowed 'own', 'jaxopt'")
    if self.damping not in ("trainlm", "nielsen"):
      raise errors.SettingError(
          f"damping={self.damping!r} is unknown: allowed 'trainlm', 'nielsen'")
    if not (np.isfinite(self.weight_decay) and 0 <= self.weight_decay <= 1e6):
      raise errors.SettingError(f"weight_decay={self.weight_decay!r} is out of range: "
                                f"allowed [0, 1e6]")
    if self.weight_decay and self.backend != "own":
      raise errors.SettingError("weight_decay needs backend='own' (jaxopt's LM has none)")


@dataclasses.dataclass(frozen=True)
class MinMax:
  """Affine map of each column from [lo, hi] to [-1, 1]; constant columns map to 0."""
  lo: np.ndarray
  hi: np.ndarray

  @staticmethod
  def fit(a: np.ndarray) -> "MinMax":
    return MinMax(a.min(axis=0), a.max(axis=0))

  def _half(self):
    span = self.hi - self.lo
    return np.where(span > 0, span / 2, 1.0), (self.hi + self.lo) / 2

  def forward(self, a):
    half, mid = self._half()
    return (a - mid) / half

  def inverse(self, s):
    half, mid = self._half()
    return s * half + mid


@dataclasses.dataclass(frozen=True)
class MLP(Part):
  """A fitted network: weights and the input/output scalings (plain arrays).

  Attributes:
    w1: (H, D + 1) hidden weights, bias last.  w2: (O, H + 1) output weights, bias last.
    x_scale, y_scale: mapminmax of inputs and outputs.
  """
  w1: np.ndarray
  w2: np.ndarray
  x_scale: MinMax
  y_scale: MinMax

  @float64
  def predict(self, x: np.ndarray) -> np.ndarray:
    x = linear.check_array(x, "inputs", self.w1.shape[1] - 1)
    xp, _ = _padded(self.x_scale.forward(x))  # one compilation per size class, not per size
    s = np.asarray(_forward_jit(_pack(self.w1, self.w2), xp, self.w1.shape[0], x.shape[1],
                                self.w2.shape[0]))[:len(x)]
    return self.y_scale.inverse(s)

  NAME, C_TAG, LABEL = "mlp", "NET", "NN"
  RESIDUAL_LABEL = "LSANN"  # the method of LS plus this network on its residual

  @property
  def n_inputs(self) -> int:
    return self.w1.shape[1] - 1

  @property
  def n_outputs(self) -> int:
    return self.w2.shape[0]

  @property
  def tame(self) -> bool:
    return False

  def without_outputs(self, outputs: np.ndarray) -> "MLP":
    """The network with its contribution removed on `outputs` (bool (A,)): their output
    scaling maps to exactly 0, so every consumer (predict, the C export) sees nothing."""
    lo = np.where(outputs, 0.0, self.y_scale.lo)
    hi = np.where(outputs, 0.0, self.y_scale.hi)
    w2 = np.where(outputs[:, None], 0.0, self.w2)  # a zero scaled output, mapped to 0
    return dataclasses.replace(self, w2=w2, y_scale=MinMax(lo, hi))

  def leaves(self) -> tuple[dict, dict]:
    return {"w1": self.w1, "w2": self.w2, "x_lo": self.x_scale.lo, "x_hi": self.x_scale.hi,
            "y_lo": self.y_scale.lo, "y_hi": self.y_scale.hi}, {}

  @classmethod
  def from_leaves(cls, spec, arrays, children=None) -> "MLP":
    net = cls(arrays["w1"], arrays["w2"], MinMax(arrays["x_lo"], arrays["x_hi"]),
              MinMax(arrays["y_lo"], arrays["y_hi"]))
    (h, d1), a = np.shape(net.w1) if np.ndim(net.w1) == 2 else (-1, -1), \
        np.shape(net.w2)[0] if np.ndim(net.w2) == 2 else -1
    check_shapes("network", arrays, {"w2": (a, h + 1), "x_lo": (d1 - 1,), "x_hi": (d1 - 1,),
                                     "y_lo": (a,), "y_hi": (a,)})
    return net

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> None:
    """mapminmax, the tanh hidden layer, the linear output, added to acc[]."""
    h, d1 = self.w1.shape
    c, a = d1 - 1, self.w2.shape[0]  # the first d1 - 1 inputs
    xhalf, xmid = self.x_scale._half()
    yhalf, ymid = self.y_scale._half()
    xm, xi = em.array(f"{tag}_XMID", xmid), em.array(f"{tag}_XINV", 1.0 / xhalf)
    w1, w2 = em.array(f"{tag}_W1", self.w1), em.array(f"{tag}_W2", self.w2)
    ym, yh = em.array(f"{tag}_YMID", ymid), em.array(f"{tag}_YHALF", yhalf)
    em.costs(macs=h * d1 + a * (h + 1) + c + a, tanh=h, stack=4 * (c + h))
    em.code += [
        "  { /* network: mapminmax, tanh hidden layer, linear output */",
        f"    float s[{c}], hid[{h}];",
        f"    for (int i = 0; i < {c}; ++i) s[i] = (x[i] - {xm}[i]) * {xi}[i];",
        f"    for (int k = 0; k < {h}; ++k) {{",
        f"      float v = {w1}[k * {d1} + {c}];",
        f"      for (int i = 0; i < {c}; ++i) v += {w1}[k * {d1} + i] * s[i];",
        "      hid[k] = tanhf(v);",
        "    }",
        f"    for (int j = 0; j < {a}; ++j) {{",
        f"      float v = {w2}[j * {h + 1} + {h}];",
        f"      for (int k = 0; k < {h}; ++k) v += {w2}[j * {h + 1} + k] * hid[k];",
        f"      {acc}[j] += v * {yh}[j] + {ym}[j];",
        "    }",
        "  }"]


@dataclasses.dataclass(frozen=True)
class TrainResult:
  """A trained network and how training went.

  Attributes:
    net: the weights at the best validation epoch.
    epochs: epochs run.
    stop: why training ended.
    train_mse, val_mse: (epochs + 1,) MSE per epoch in output units (N^2 for forces),
      epoch 0 being the start point.
    seconds: wall time of the epochs after compilation, s.  compile_seconds: JIT time, s.
    best_epoch: epoch whose weights `net` holds.
    times: (epochs + 1,) wall time after compilation at the end of each epoch, s (0 first).
    snapshots: {epoch cap: (the net at the best validation epoch up to the cap, that epoch)}
      for the caps `train` was asked for: what training with `epochs=cap` would return.
  """
  net: MLP
  epochs: int
  stop: Stop
  train_mse: np.ndarray
  val_mse: np.ndarray
  seconds: float
  compile_seconds: float
  best_epoch: int
  times: Optional[np.ndarray] = None
  snapshots: Optional[dict] = None

  @property
  def best_val_mse(self) -> float:
    return float(self.val_mse[self.best_epoch])

  def epochs_to(self, target: float) -> Optional[int]:
    """First epoch whose validation MSE is at or below target; None if never."""
    hit = np.flatnonzero(self.val_mse <= target)
    return int(hit[0]) if hit.size else None


def _pack(w1, w2):
  return jnp.concatenate([jnp.ravel(w1), jnp.ravel(w2)])


def _unpack(theta, h, d, o):
  n1 = h * (d + 1)
  return theta[:n1].reshape(h, d + 1), theta[n1:].reshape(o, h + 1)


def _layers(w1, x):
  """(inputs with a bias column, hidden activations, hidden with a bias column)."""
  a = jnp.concatenate([x, jnp.ones((x.shape[0], 1), x.dtype)], axis=1)
  hid = jnp.tanh(a @ w1.T)
  return a, hid, jnp.concatenate([hid, jnp.ones((x.shape[0], 1), x.dtype)], axis=1)


def _forward(theta, x, h, d, o):
  w1, w2 = _unpack(theta, h, d, o)
  return _layers(w1, x)[2] @ w2.T


_forward_jit = jax.jit(_forward, static_argnums=(2, 3, 4))


# Samples per Gram block: a block's products stay in cache. Measured at N = 100k, one
# thread: 4096 was the fastest of 1024-16384 (22-33 ms per set of normal equations against
# 28-41 ms at 16384, the machine's load moving both), and two trainings side by side slowed
# each other by 1.15x at 2048-4096 against 1.66x at 16384, whose blocks stream through memory.
_CHUNK = 4096


def normal_equations(theta, x, y, h: int, mask=None):
  """(J^T J (P, P), J^T e (P,), sum of squared errors) for e = y - net(x), from the layers.

  J is the Jacobian of the stacked outputs (N O) with respect to theta. Samples are taken in
  blocks of `_CHUNK` (zero-padded, padding masked out) and their Gram matrices summed.
  mask: (N,) 1 for a sample, 0 for a padding row (None: every row a sample).
  """
  jtj, jte, sse = _normal_equations(theta, x, y, h, mask)
  return jtj, jte, jnp.sum(sse)


def _normal_equations(theta, x, y, h: int, mask=None):
  """`normal_equations` with the squared errors summed per output: (O,)."""
  n, d = x.shape
  o = y.shape[1]
  nz = h * (d + 1)
  w1, w2 = _unpack(theta, h, d, o)
  s = w2[:, :h]  # (O, H) output weights without bias
  chunks = -(-n // _CHUNK)
  pad = chunks * _CHUNK - n
  mask = jnp.ones(n, x.dtype) if mask is None else jnp.asarray(mask, x.dtype)
  mask = jnp.concatenate([mask, jnp.zeros(pad, x.dtype)]).reshape(chunks, -1)
  xc = jnp.pad(x, ((0, pad), (0, 0))).reshape(chunks, _CHUNK, d)
  yc = jnp.pad(y, ((0, pad), (0, 0))).reshape(chunks, _CHUNK, o)

  ih, jh = np.triu_indices(h)  # the distinct products of two hidden units' slopes
  ka, la = np.triu_indices(d + 1)  # and of two inputs
  pair_h = np.zeros((h, h), int)
  pair_h[ih, jh] = pair_h[jh, ih] = np.arange(len(ih))
  pair_a = np.zeros((d + 1, d + 1), int)
  pair_a[ka, la] = pair_a[la, ka] = np.arange(len(ka))

  def block(acc, inp):
    xb, yb, mb = inp
    a, hid, hh = _layers(w1, xb)
    e = (yb - hh @ w2.T) * mb[:, None]
    g = (1.0 - hid**2) * mb[:, None]
    hm = hh * mb[:, None]
    # The Gram matrix of the per-sample vector u = [(1 - h^2) (x) (x, 1), h, 1] holds every
    # block of J^T J. Its (x) part is sum_n g_i g_j a_k a_l: one product of the distinct
    # g_i g_j with the distinct a_k a_l (H(H+1)/2 by (D+1)(D+2)/2), half the work of u^T u.
    gg, aa = g[:, ih] * g[:, jh], a[:, ka] * a[:, la]
    ga = (g[:, :, None] * hm[:, None, :]).reshape(_CHUNK, h * (h + 1))
    kron, cross, tail, g1, g2, sse = acc
    return (kron + gg.T @ aa, cross + ga.T @ a, tail + hm.T @ hm,
            g1 + ((e @ s) * g).T @ a, g2 + e.T @ hh, sse + jnp.sum(e**2, axis=0)), None

  zero = (jnp.zeros((len(ih), len(ka)), x.dtype), jnp.zeros((h * (h + 1), d + 1), x.dtype),
          jnp.zeros((h + 1, h + 1), x.dtype), jnp.zeros((h, d + 1), x.dtype),
          jnp.zeros((o, h + 1), x.dtype), jnp.zeros((o,), x.dtype))
  (kron, cross, tail, g1, g2, sse), _ = jax.lax.scan(block, zero, (xc, yc, mask))
  top = kron[pair_h[:, None, :, None], pair_a[None, :, None, :]].reshape(nz, nz)
  side = cross.reshape(h, h + 1, d + 1).transpose(0, 2, 1).reshape(nz, h + 1)
  gram = jnp.block([[top, side], [side.T, tail]])
  ones = jnp.ones((d + 1,), x.dtype)
  b11 = gram[:nz, :nz] * jnp.kron(s.T @ s, jnp.outer(ones, ones))
  zh = gram[:nz, nz:]  # (H (D+1), H+1)
  b12 = jnp.concatenate([zh * jnp.kron(s[k], ones)[:, None] for k in range(o)], axis=1)
  b22 = jnp.kron(jnp.eye(o, dtype=x.dtype), gram[nz:, nz:])
  jtj = jnp.block([[b11, b12], [b12.T, b22]])
  return jtj, jnp.concatenate([g1.ravel(), g2.ravel()]), sse


def residuals(theta, x, y, h: int):
  """(N O,) residuals e = y - net(x), outputs stacked per sample."""
  return (y - _forward(theta, x, h, x.shape[1], y.shape[1])).ravel()


def jacobian(theta, x, y, h: int):
  """(N O, P) Jacobian of `residuals` with respect to theta, from the layers in closed form
  (what `normal_equations` builds its Gram blocks from), not by automatic differentiation:
  d e[n, o] / d w1[j, k] = -w2[o, j] (1 - hid[n, j]^2) a[n, k] and
  d e[n, o] / d w2[o', j] = -[o = o'] hh[n, j]. The solvers `lm_solvers` races are all given
  this one, so the race times the solvers and not each library's Jacobian assembly."""
  n, d = x.shape
  o = y.shape[1]
  w1, w2 = _unpack(theta, h, d, o)
  a, hid, hh = _layers(w1, x)
  g = 1.0 - hid**2  # (N, H)
  j1 = -(w2[None, :, :h, None] * g[:, None, :, None] * a[:, None, None, :])  # (N, O, H, D+1)
  j2 = -(jnp.eye(o, dtype=x.dtype)[None, :, :, None] * hh[:, None, None, :])  # (N, O, O, H+1)
  return jnp.concatenate([j1.reshape(n, o, -1), j2.reshape(n, o, -1)], axis=2).reshape(
      n * o, -1)


@float64
@functools.partial(jax.jit, static_argnums=(1, 2, 3))  # one compilation, not one per draw
def nguyen_widrow(key, d: int, h: int, o: int) -> jnp.ndarray:
  """Start point: Nguyen-Widrow hidden layer for inputs in [-1, 1], small random outputs.

  Hidden weights get random directions of norm 0.7 H^(1/D) and biases spread over
  [-norm, norm] so the units' active regions tile the input box (MATLAB `initnw`).
  """
  k1, k2, k3 = jax.random.split(key, 3)
  beta = 0.7 * h ** (1.0 / d)
  w = jax.random.uniform(k1, (h, d), jnp.float64, -1.0, 1.0)
  w = beta * w / jnp.linalg.norm(w, axis=1, keepdims=True)
  b = beta * jnp.linspace(-1.0, 1.0, h) * jnp.sign(jax.random.uniform(k2, (h,), jnp.float64,
                                                                       -1.0, 1.0))
  w2 = jax.random.uniform(k3, (o, h + 1), jnp.float64, -1.0, 1.0) * (1.0 / np.sqrt(h + 1))
  return _pack(jnp.column_stack([w, b]), w2)


def _sse_per_output(theta, x, y, h: int, mask=None):
  """(O,) squared errors summed per output; `mask` (N,) leaves the padding rows out."""
  r = residuals(theta, x, y, h).reshape(-1, y.shape[1])
  return jnp.sum((r if mask is None else r * mask[:, None]) ** 2, axis=0)


def _lm_epoch_fn(h: int, cfg: LMConfig):
  """jit-compiled epoch: try damped steps until one lowers the error or mu passes mu_max.

  The state is (mu, nu); nu is used by the "nielsen" damping only. `mask` (N,) marks the
  samples among padding rows (None: none padded); `count`: their number times the outputs.
  Returns (theta, state, squared errors per output at theta, gradient norm of the MSE).
  """

  def epoch(theta, state, x, y, mask=None, count=None):
    count = y.size if count is None else count
    jtj, jte, sse = _normal_equations(theta, x, y, h, mask)
    eye = jnp.eye(jtj.shape[0], dtype=jtj.dtype)
    lam = cfg.weight_decay
    if lam:  # Gauss-Newton on the residuals and sqrt(lam) theta: the penalty's own terms
      jtj, jte = jtj + lam * eye, jte - lam * theta

    def try_step(trial):
      _, mu, nu, _, _ = trial
      c, low = jax.scipy.linalg.cho_factor(jtj + mu * eye)
      delta = jax.scipy.linalg.cho_solve((c, low), jte)
      sse_new = _sse_per_output(theta + delta, x, y, h, mask)
      gain = jnp.sum(sse) - jnp.sum(sse_new)
      if lam:
        gain += lam * (theta @ theta - (theta + delta) @ (theta + delta))
      ok = gain > 0  # NaN from a failed factorisation counts as a failure
      if cfg.damping == "trainlm":
        mu_next, nu_next = jnp.where(ok, mu * cfg.mu_dec, mu * cfg.mu_inc), nu
      else:  # predicted decrease of the linear model: delta^T (mu delta + J^T e)
        rho = gain / (delta @ (mu * delta + jte))
        mu_next = jnp.where(ok, mu * jnp.maximum(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3),
                            mu * nu)
        nu_next = jnp.where(ok, 2.0, 2.0 * nu)
      return theta + delta, mu_next, nu_next, sse_new, ok

    def keep_trying(trial):
      return (~trial[4]) & (trial[1] <= cfg.mu_max)

    mu, nu = state
    cand, mu, nu, sse_new, ok = jax.lax.while_loop(
        keep_trying, try_step, (theta, mu, nu, sse, jnp.array(False)))
    theta = jnp.where(ok, cand, theta)
    grad = 2.0 * jnp.linalg.norm(jte) / count
    return theta, (mu, nu), jnp.where(ok, sse_new, sse), grad

  return jax.jit(epoch)


def _jaxopt_epoch_fn(h: int, cfg: LMConfig):
  import jaxopt  # the baseline backend is optional at import time

  def masked(t, x, y, mask):
    return residuals(t, x, y, h) * jnp.repeat(mask, y.shape[1])

  solver = jaxopt.LevenbergMarquardt(masked, maxiter=1, damping_parameter=cfg.mu,
                                     solver="cholesky", materialize_jac=True)

  def epoch(theta, state, x, y, mask, count):
    theta, state = solver.update(theta, state, x, y, mask)
    return (theta, state, _sse_per_output(theta, x, y, h, mask),
            2.0 * jnp.linalg.norm(state.gradient) / count)

  return solver, epoch


def _rows(n: int) -> int:
  """The rows a set of n samples is padded to (masked out): a power of two from 64 up to
  `_CHUNK`, then a multiple of it (what the normal equations pad to anyway). Sets of nearby
  sizes (a cross-validation's folds, an ensemble's members) then share one compiled epoch."""
  return max(64, 1 << (n - 1).bit_length()) if n <= _CHUNK else -(-n // _CHUNK) * _CHUNK


def _padded(a: np.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
  """(`a` (N, C) with zero rows up to `_rows(N)`, its mask (rows,): 1 for a sample)."""
  rows = _rows(len(a))
  mask = np.zeros(rows)
  mask[:len(a)] = 1.0
  return jnp.asarray(np.pad(a, ((0, rows - len(a)), (0, 0)))), jnp.asarray(mask)


def _kernel(config: LMConfig):
  """`_compiled` for `config`, whatever its stopping rules (the host loop's, not the step's)
  and, on the own backend, its start mu (the state `train` passes in, not the step's)."""
  return _compiled(dataclasses.replace(
      config, epochs=1, max_fail=1, min_grad=1.0, goal=0.0,
      mu=LMConfig.mu if config.backend == "own" else config.mu))


@functools.lru_cache(maxsize=64)
def _compiled(config: LMConfig):
  """(jaxopt's solver or None, step(theta, state, data) -> (theta, state, [train MSE, val MSE,
  gradient, scaled MSE, mu]), scores(theta, data) -> [train MSE, val MSE]) of networks trained
  with `config` (its hidden units and damping; its stopping rules are `_epochs`'), jitted once
  with the data as arguments (`train`'s `data`, padded by `_rows`): every fit of one shape (a
  cross-validation's folds, an ensemble's members, the widths' refits) reuses one compilation,
  where a step closing over its data compiled again for each (measured, one `fit_auto` of
  1500 samples on 3 folds: 8 compilations of the step, 6.2 s, then 2, 1.7 s; every
  compilation of the fit 13.6 s, then 7.9 s). MSEs in output units."""
  h = int(config.hidden)
  if config.backend == "own":
    solver, inner = None, _lm_epoch_fn(h, config)
  else:
    solver, inner = _jaxopt_epoch_fn(h, config)

  def mses(theta, sse, data):
    """[train MSE from the scaled squared errors `sse` (O,), validation MSE at theta]."""
    xj, yj, _, xvj, yvs, vmask, half, count, vcount = data
    err = (_forward(theta, xvj, h, xj.shape[1], yj.shape[1]) - yvs) * half * vmask[:, None]
    return [jnp.sum(sse * half**2) / count, jnp.sum(err ** 2) / vcount]

  @jax.jit
  def step(theta, state, data):
    xj, yj, mask, count = data[0], data[1], data[2], data[7]
    theta, state, sse, grad = inner(theta, state, xj, yj, mask, count)
    mu = state[0] if solver is None else jnp.asarray(0.0)
    return theta, state, jnp.stack([*mses(theta, sse, data), grad, jnp.sum(sse) / count, mu])

  @jax.jit
  def scores(theta, data):
    return jnp.stack(mses(theta, _sse_per_output(theta, data[0], data[1], h, data[2]), data))

  return solver, step, scores


@float64
def train(x: np.ndarray, y: np.ndarray, x_val: np.ndarray, y_val: np.ndarray,
          config: LMConfig = LMConfig(), seed: int = 0,
          progress: Optional[Callable[[int, int], None]] = None,
          start: Optional[np.ndarray] = None, snapshots: tuple[int, ...] = ()) -> TrainResult:
  """Fits the network to (x, y), stopping on the validation set (x_val, y_val).

  Args:
    x, y: (N, D) inputs and (N, O) targets.  x_val, y_val: held-out validation samples.
    config: LM settings.  seed: integer driving the Nguyen-Widrow start (JAX key).
    progress: called as progress(epoch, config.epochs) after each epoch, and once as
      progress(epoch, epoch) when training stops before the cap.
    start: optional parameter vector to start from instead of Nguyen-Widrow.
    snapshots: epoch caps at which to keep the best net so far (`TrainResult.snapshots`), so
      one run stands for the runs with those smaller `epochs`.
  """
  x, y, x_val, y_val = _checked(x, y, x_val, y_val, config)
  h, d, o = int(config.hidden), x.shape[1], y.shape[1]
  xs, ys = MinMax.fit(x), MinMax.fit(y)
  theta = (nguyen_widrow(jax.random.key(seed), d, h, o) if start is None
           else jnp.asarray(start, jnp.float64))
  t0 = time.perf_counter()
  (xp, mask), (yp, _) = _padded(xs.forward(x)), _padded(ys.forward(y))
  (xvp, vmask), (yvp, _) = _padded(xs.forward(x_val)), _padded(ys.forward(y_val))
  data = (xp, yp, mask, xvp, yvp, vmask, jnp.asarray(ys._half()[0]),
          jnp.asarray(float(y.size)), jnp.asarray(float(y_val.size)))
  solver, step, scores = _kernel(config)
  state = ((jnp.asarray(config.mu), jnp.asarray(2.0)) if solver is None
           else solver.init_state(theta, xp, yp, mask))
  jax.block_until_ready(step(theta, state, data))  # compile on the start point (or reuse)
  first = tuple(np.asarray(scores(theta, data)).tolist())
  compile_s = time.perf_counter() - t0
  run = _epochs(lambda t, st: step(t, st, data), theta, state, config, progress, snapshots,
                first)

  def net(theta):
    w1, w2 = (np.asarray(w) for w in _unpack(theta, h, d, o))
    return MLP(w1, w2, xs, ys)
  return TrainResult(net(run["best"]), run["epochs"], run["stop"], np.array(run["train"]),
                     np.array(run["val"]), run["seconds"], compile_s, run["best_epoch"],
                     np.array(run["times"]),
                     {cap: (net(t), e) for cap, (t, e) in run["kept"].items()})


def _checked(x, y, x_val, y_val, config: LMConfig):
  """The training and validation arrays, checked against each other and the network's size."""
  config.validate()
  x, y = linear.check_pair(x, y)
  x_val, y_val = linear.check_pair(x_val, y_val)
  if x_val.shape[1] != x.shape[1] or y_val.shape[1] != y.shape[1]:
    raise errors.DataError(f"validation columns {x_val.shape[1]}/{y_val.shape[1]} differ from "
                           f"training columns {x.shape[1]}/{y.shape[1]}")
  h, d, o = int(config.hidden), x.shape[1], y.shape[1]
  n_par = h * (d + 1) + o * (h + 1)
  if y.size <= n_par:
    raise errors.DataError(
        f"{len(x)} training samples ({len(x_val)} held out for validation) x {o} outputs "
        f"cannot fit {n_par} network parameters: a network of {h} hidden units needs more "
        f"than {n_par // o} training samples (or --hidden smaller)")
  if len(x_val) == 0:
    raise errors.DataError("the validation set is empty: hold out some samples")
  return x, y, x_val, y_val


def _epochs(step, theta, state, config: LMConfig, progress, snapshots, first) -> dict:
  """Epochs until a stop (`Stop`); the best network on validation and the snapshots."""
  train_hist, val_hist, times = [first[0]], [first[1]], [0.0]
  best, best_epoch, fails, stop = theta, 0, 0, Stop.MAX_EPOCHS
  kept = {}
  t1 = time.perf_counter()
  for ep in range(1, config.epochs + 1):
    theta, state, info = step(theta, state)
    tr, va, grad, mse_scaled, mu = np.asarray(info).tolist()
    train_hist.append(tr)
    val_hist.append(va)
    times.append(time.perf_counter() - t1)
    if progress:
      progress(ep, config.epochs)
    if va < val_hist[best_epoch]:
      best, best_epoch, fails = theta, ep, 0
    else:
      fails += 1
    if ep in snapshots:
      kept[ep] = (best, best_epoch)
    stop = _stop(config, mu, fails, grad, mse_scaled)
    if stop is not None:
      break
  seconds = time.perf_counter() - t1
  if progress and ep < config.epochs:
    progress(ep, ep)  # stopped early: the stage is over, its bar or line closes
  # caps past the stop return what the stop returned
  kept.update({cap: (best, best_epoch) for cap in snapshots if cap not in kept})
  return {"best": best, "epochs": ep, "stop": stop or Stop.MAX_EPOCHS, "train": train_hist,
          "val": val_hist, "seconds": seconds, "best_epoch": best_epoch, "times": times,
          "kept": kept}


def _stop(config: LMConfig, mu, fails, grad, mse_scaled) -> Optional[Stop]:
  """Why training stops after this epoch (trainlm's rules), or None."""
  if config.backend == "own" and mu > config.mu_max:
    return Stop.MU_MAX
  if fails >= config.max_fail:
    return Stop.VALIDATION
  if grad < config.min_grad:
    return Stop.MIN_GRADIENT
  if mse_scaled <= config.goal:
    return Stop.GOAL
  return None
