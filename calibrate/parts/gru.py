"""A small gated recurrent network (GRU) in JAX: the residual a static map leaves, from the
recording's past.

The cell (PyTorch's `nn.GRU` equations, so its weights read the same), for inputs x_t (D,)
and hidden state h (H,):

  r = sigmoid(W_r x_t + b_r + U_r h),  z = sigmoid(W_z x_t + b_z + U_z h)
  n = tanh(W_n x_t + b_n + r * (U_n h + c_n)),  h' = (1 - z) * n + z * h
  y_t = V h' + v

with inputs standardised (`x_mean`, `x_scale`) and outputs in standardised units (`y_mean`,
`y_scale`). The state starts at zero at the start of every recording (`segments`), as it
does on the sensor's microcontroller at power-up or after `estimate_reset()` or
`estimate_restart()`.

Training (`train`) is truncated back-propagation through time on windows cut from the
training recordings, never across a recording's end: a window of `GRUConfig.window` samples
starts every window - burn_in samples, and only a window that starts its recording scores
its first `burn_in` samples (elsewhere the state there is not yet the one `predict` carries
in). Adam on the mean squared error of the selected samples, float64, seeded; early stopping
on held-out recordings (whole ones; with few recordings, contiguous blocks of them, never
single samples beside training ones), keeping the weights of the best held-out check.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable, Optional

import jax
import jax.numpy as jnp
import numpy as np

from calibrate.parts import mlp
from calibrate.cexport.emitter import literal
from calibrate.parts.base import Part, Stream
from util import errors, fields
from util.fields import setting


@fields.declared
@dataclasses.dataclass(frozen=True)
class GRUConfig:
  """Training settings.

  Attributes:
    hidden: H, hidden units (8-16: what a Cortex-M3 steps at 1 kHz in fixed point,
      `cexport`).
    window: samples per training window.
    burn_in: samples at the start of a window that is not its recording's start that the
      loss skips.
    batch: windows per Adam step.
    learning_rate: Adam's step size.
    steps: the cap on Adam steps.
    check: steps between held-out evaluations.
    patience: held-out evaluations in a row without a better error that stop training.
    val_fraction: share held out for the early stop (one recording or block at least).
    min_recordings: with this many recordings or more, whole recordings are held out; with
      fewer, contiguous blocks of `block` samples (a recording's past still runs through
      the state; the held-out block's targets never reach the loss).
    block: samples per held-out block.
  """
  hidden: int = setting(8, "[1, 256]")
  window: int = setting(512, "[8, 1e6]")
  burn_in: int = setting(128, "[0, 1e6]")
  batch: int = setting(16, "[1, 1e5]")
  learning_rate: float = setting(1e-2, "(0, 1]")
  steps: int = setting(3000, "[1, 1e7]")
  check: int = setting(50, "[1, 1e6]")
  patience: int = setting(10, "[1, 1e6]")
  val_fraction: float = setting(0.2, "(0, 1)")
  min_recordings: int = setting(5, "[2, 1e6]")
  block: int = setting(2000, "[8, 1e7]")

  def relations(self):
    """Checks between fields (`fields.check` runs them after each field's own range)."""
    yield self.burn_in < self.window, "burn_in", f"0 to window - 1 ({self.window - 1})", \
        self.burn_in

  def validate(self) -> None:
    fields.check(self)


@dataclasses.dataclass(frozen=True)
class GRU(Part):
  """A fitted cell and its scalings (plain float64 arrays).

  Attributes:
    w: (3H, D) input weights, gates r, z, n stacked.  u: (3H, H) recurrent weights.
    b: (3H,) input biases.  c: (H,) the n gate's recurrent bias.
    v: (A, H) output weights.  v0: (A,) output bias.
    x_mean, x_scale: (D,) input standardisation.  y_mean, y_scale: (A,) output's.
  """
  w: np.ndarray
  u: np.ndarray
  b: np.ndarray
  c: np.ndarray
  v: np.ndarray
  v0: np.ndarray
  x_mean: np.ndarray
  x_scale: np.ndarray
  y_mean: np.ndarray
  y_scale: np.ndarray

  FIELDS = ("w", "u", "b", "c", "v", "v0", "x_mean", "x_scale", "y_mean", "y_scale")

  @property
  def hidden(self) -> int:
    return self.u.shape[1]

  @property
  def inputs(self) -> int:
    return self.w.shape[1]

  def check(self) -> None:
    """Raises ValueError when the arrays do not fit together."""
    h, d, a = self.hidden, self.inputs, self.v.shape[0]
    shapes = {"w": (3 * h, d), "u": (3 * h, h), "b": (3 * h,), "c": (h,), "v": (a, h),
              "v0": (a,), "x_mean": (d,), "x_scale": (d,), "y_mean": (a,), "y_scale": (a,)}
    bad = [k for k, s in shapes.items() if getattr(self, k).shape != s]
    if bad:
      raise ValueError(f"the recurrent network's arrays {', '.join(bad)} do not fit together")

  @mlp.float64
  def predict(self, x: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(N, A) outputs for (N, D) inputs in time order; starts (N,) bool marks the first
    sample of each recording, where the state is zero."""
    xs = jnp.asarray((np.asarray(x, float) - self.x_mean) / self.x_scale)
    p = {k: jnp.asarray(getattr(self, k)) for k in ("w", "u", "b", "c", "v", "v0")}
    out = _run_reset(p, xs, jnp.asarray(starts, bool))
    return np.asarray(out) * self.y_scale + self.y_mean

  NAME, C_TAG, LABEL = "gru", "GRU", "GRU"
  RESIDUAL_LABEL = "GRU"  # LS plus this network on its residual is still called GRU

  @property
  def n_inputs(self) -> int:
    return self.inputs

  @property
  def n_outputs(self) -> int:
    return self.v.shape[0]

  @property
  def tame(self) -> bool:
    return False

  def mean_spread(self, x, stream=None):
    first = (stream or Stream()).starts(len(x))
    return self.predict(x[:, :self.inputs], first), None

  def leaves(self) -> tuple[dict, dict]:
    return {f: getattr(self, f) for f in self.FIELDS}, {}

  @classmethod
  def from_leaves(cls, spec, arrays, children=None) -> "GRU":
    net = cls(*(arrays[f] for f in cls.FIELDS))
    net.check()
    return net

  def emit_c(self, em, tag: str, c: int, acc: str = "acc") -> None:
    """The network on the first D of x[], its state in a static array that
    `estimate_restart` zeroes; sigmoid(v) as 0.5 + 0.5 tanhf(v / 2). In Q16 when the
    emitter asks for fixed point (`_emit_fixed`)."""
    if em.fixed:
      return self._emit_fixed(em, tag, acc)
    h, d, a = self.hidden, self.inputs, self.v.shape[0]
    xm, xi, w, u, b, c, v, v0, ym, ys = self._arrays(em, tag, em.array, "")
    em.state.append(f"static float {tag}_H[{h}];")
    em.resets.append(f"  for (int k = 0; k < {h}; ++k) {tag}_H[k] = 0.0f;")
    em.costs(macs=d + 3 * h * (d + h) + 6 * h + a * (h + 1), tanh=3 * h,
             stack=4 * (d + 4 * h))
    em.code += [
        "  { /* recurrent network (GRU): standardise, gates r, z, n, new state, linear output */",
        f"    float s[{d}], g[{3 * h}], hn[{h}];",
        f"    for (int i = 0; i < {d}; ++i) s[i] = (x[i] - {xm}[i]) * {xi}[i];",
        f"    for (int k = 0; k < {3 * h}; ++k) {{",
        f"      float e = {b}[k];",
        f"      for (int i = 0; i < {d}; ++i) e += {w}[k * {d} + i] * s[i];",
        "      g[k] = e;",
        "    }",
        f"    for (int k = 0; k < {h}; ++k) {{",
        f"      float ur = 0.0f, uz = 0.0f, un = {c}[k];",
        f"      for (int j = 0; j < {h}; ++j) {{",
        f"        ur += {u}[k * {h} + j] * {tag}_H[j];",
        f"        uz += {u}[({h} + k) * {h} + j] * {tag}_H[j];",
        f"        un += {u}[({2 * h} + k) * {h} + j] * {tag}_H[j];",
        "      }",
        "      float r = 0.5f + 0.5f * tanhf(0.5f * (g[k] + ur));",
        f"      float z = 0.5f + 0.5f * tanhf(0.5f * (g[{h} + k] + uz));",
        f"      float n = tanhf(g[{2 * h} + k] + r * un);",
        f"      hn[k] = (1.0f - z) * n + z * {tag}_H[k];",
        "    }",
        f"    for (int k = 0; k < {h}; ++k) {tag}_H[k] = hn[k];",
        f"    for (int j = 0; j < {a}; ++j) {{",
        f"      float e = {v0}[j];",
        f"      for (int k = 0; k < {h}; ++k) e += {v}[j * {h} + k] * {tag}_H[k];",
        f"      {acc}[j] += e * {ys}[j] + {ym}[j];",
        "    }",
        "  }"]

  def _arrays(self, em, tag: str, weights, prefix: str) -> list[str]:
    """The names of its arrays: the input and output scalings in float, the weights written
    by `weights` (`em.array`, or `em.ints` for Q16) under names with `prefix`."""
    names = [em.array(f"{tag}_XMEAN", self.x_mean), em.array(f"{tag}_XINV", 1 / self.x_scale)]
    names += [weights(f"{tag}_{prefix}{f.upper()}", getattr(self, f))
              for f in ("w", "u", "b", "c", "v", "v0")]
    return names + [em.array(f"{tag}_YMEAN", self.y_mean),
                    em.array(f"{tag}_YSCALE", self.y_scale)]

  def _emit_fixed(self, em, tag: str, acc: str) -> None:
    """The gates and the state in Q16 fixed point (int32 values, int64 sums; tanh from a
    513-entry table at steps of 1/64, linear between: within 2.3e-5 of tanh), which in float
    cost the Cortex-M3 its soft-float tanhf calls. Inputs are standardised and the output
    scaled in float."""
    h, d, a = self.hidden, self.inputs, self.v.shape[0]
    if "TANH_Q16" not in "".join(em.arrays):
      em.ints("TANH_Q16", np.tanh(np.arange(513) / 64.0))
      em.state += TANH_Q16_CODE
    xm, xi, w, u, b, c, v, v0, ym, ys = self._arrays(em, tag, em.ints, "Q")
    em.state.append(f"static int32_t {tag}_HQ[{h}];")
    em.resets.append(f"  for (int k = 0; k < {h}; ++k) {tag}_HQ[k] = 0;")
    # the float standardisation and output scaling; a float-to-int conversion (lrintf) costs
    # about two multiply-adds (measured with the rest: 160 instructions)
    em.costs(macs=3 * d + 2 * a, fixed_macs=3 * h * (d + h) + 2 * h + a * h,
             fixed_tanh=3 * h, stack=4 * (d + 4 * h))
    em.code += [
        "  { /* recurrent network (GRU) in Q16 fixed point; >> on negative values is the",
        "     * arithmetic shift of gcc, clang and armcc */",
        f"    int32_t s[{d}], g[{3 * h}], hn[{h}];",
        f"    for (int i = 0; i < {d}; ++i) s[i] = (int32_t)lrintf((x[i] - {xm}[i]) * {xi}[i] "
        "* 65536.0f);",
        f"    for (int k = 0; k < {3 * h}; ++k) {{",
        f"      int64_t e = (int64_t){b}[k] * 65536;",
        f"      for (int i = 0; i < {d}; ++i) e += (int64_t){w}[k * {d} + i] * s[i];",
        "      g[k] = (int32_t)(e >> 16);",
        "    }",
        f"    for (int k = 0; k < {h}; ++k) {{",
        f"      int64_t ur = 0, uz = 0, un = (int64_t){c}[k] * 65536;",
        f"      for (int j = 0; j < {h}; ++j) {{",
        f"        ur += (int64_t){u}[k * {h} + j] * {tag}_HQ[j];",
        f"        uz += (int64_t){u}[({h} + k) * {h} + j] * {tag}_HQ[j];",
        f"        un += (int64_t){u}[({2 * h} + k) * {h} + j] * {tag}_HQ[j];",
        "      }",
        "      int32_t r = (65536 + tanh_q16((g[k] + (int32_t)(ur >> 16)) / 2)) / 2;",
        f"      int32_t z = (65536 + tanh_q16((g[{h} + k] + (int32_t)(uz >> 16)) / 2)) / 2;",
        f"      int32_t n = tanh_q16(g[{2 * h} + k] + (int32_t)(((int64_t)r * (int32_t)(un >> "
        "16)) >> 16));",
        f"      hn[k] = {tag}_HQ[k] + (int32_t)(((int64_t)(65536 - z) * (n - {tag}_HQ[k])) >> 16);",
        "    }",
        f"    for (int k = 0; k < {h}; ++k) {tag}_HQ[k] = hn[k];",
        f"    for (int j = 0; j < {a}; ++j) {{",
        f"      int64_t e = (int64_t){v0}[j] * 65536;",
        f"      for (int k = 0; k < {h}; ++k) e += (int64_t){v}[j * {h} + k] * {tag}_HQ[k];",
        f"      {acc}[j] += (float)(e >> 16) * {literal(1 / 65536)} * {ys}[j] + {ym}[j];",
        "    }",
        "  }"]


TANH_Q16_CODE = [
    "static int32_t tanh_q16(int32_t v) {  /* Q16 in and out: the table, linear between */",
    "  int32_t m = v < 0 ? -v : v, y;",
    "  if (m >= (8 << 16)) y = 65536;",
    "  else {",
    "    int32_t k = m >> 10, f = m & 1023;",
    "    y = TANH_Q16[k] + (((TANH_Q16[k + 1] - TANH_Q16[k]) * f) >> 10);",
    "  }",
    "  return v < 0 ? -y : y;",
    "}"]


def _cell(p, h, x):
  """One step for a batch: h (B, H), x (B, D) -> h' (B, H)."""
  hid = p["u"].shape[1]
  gx = x @ p["w"].T + p["b"]
  gh = h @ p["u"].T
  r = jax.nn.sigmoid(gx[:, :hid] + gh[:, :hid])
  z = jax.nn.sigmoid(gx[:, hid:2 * hid] + gh[:, hid:2 * hid])
  n = jnp.tanh(gx[:, 2 * hid:] + r * (gh[:, 2 * hid:] + p["c"]))
  return (1 - z) * n + z * h


@jax.jit
def _run_reset(p, xs, starts):
  """The whole sequence (N, D), state zeroed where `starts`: (N, A)."""
  def step(h, inp):
    x, s = inp
    h = jnp.where(s, 0.0, h)
    h = _cell(p, h[None], x[None])[0]
    return h, h @ p["v"].T + p["v0"]
  h0 = jnp.zeros(p["u"].shape[1], xs.dtype)
  return jax.lax.scan(step, h0, (xs, starts), unroll=8)[1]


def _run_windows(p, xs):
  """Windows (B, L, D) from a zero state: (B, L, A)."""
  def step(h, x):
    h = _cell(p, h, x)
    return h, h @ p["v"].T + p["v0"]
  h0 = jnp.zeros((xs.shape[0], p["u"].shape[1]), xs.dtype)
  return jnp.swapaxes(jax.lax.scan(step, h0, jnp.swapaxes(xs, 0, 1), unroll=8)[1], 0, 1)


def _loss(p, xs, ys, mask):
  err = (_run_windows(p, xs) - ys) ** 2 * mask[..., None]
  return jnp.sum(err) / jnp.maximum(jnp.sum(mask) * ys.shape[-1], 1.0)


@jax.jit
def _adam_step(p, m, v, t, lr, bx, by, bm):
  """One Adam step (beta 0.9, 0.999; eps 1e-8) on a batch of windows. Module-level, so that
  fits of the same shapes (cross-validation's folds, seeds) share one compilation."""
  b1, b2, eps = 0.9, 0.999, 1e-8
  loss, g = jax.value_and_grad(_loss)(p, bx, by, bm)
  m = jax.tree.map(lambda m, g: b1 * m + (1 - b1) * g, m, g)
  v = jax.tree.map(lambda v, g: b2 * v + (1 - b2) * g * g, v, g)
  corr = jnp.sqrt(1 - b2 ** t) / (1 - b1 ** t)
  p = jax.tree.map(lambda p, m, v: p - lr * corr * m / (jnp.sqrt(v) + eps), p, m, v)
  return p, m, v, loss


_held_out_loss = jax.jit(_loss)


@dataclasses.dataclass(frozen=True)
class TrainResult:
  """How training went: Adam steps run (`epochs`, as the networks' results name it), why it
  stopped (`mlp.Stop`), the held-out MSE at every `GRUConfig.check` steps (standardised
  units; the first at the start point), the step whose weights were kept, wall seconds
  after compilation and the compilation's seconds."""
  epochs: int
  stop: mlp.Stop
  val_mse: np.ndarray
  best_epoch: int
  seconds: float
  compile_seconds: float
  held_out: tuple[tuple[int, int], ...] = ()  # the (start, stop) of the held-out recordings


def windows(runs, select: np.ndarray, window: int, burn_in: int
            ) -> list[tuple[int, int, int]]:
  """[(start, stop, first scored)] sample ranges of the training windows: each run (start,
  stop) of one recording is cut into windows of at most `window` samples every window -
  burn_in samples, none crossing the run's end; a window scores from its start when it
  starts the run, else from burn_in samples in, so every sample is scored once. Windows
  that score no selected sample are left out."""
  out = []
  stride = window - burn_in
  for lo, hi in runs:
    k = lo
    while True:
      stop = min(k + window, hi)
      first = k if k == lo else k + burn_in
      if first < stop and select[first:stop].any():
        out.append((k, stop, first))
      if stop >= hi:
        break
      k += stride
  return out


def _pack_windows(x, y, select, spans, window):
  """(B, L, D), (B, L, A), (B, L) mask arrays of the windows, zero-padded at the end."""
  b = len(spans)
  xs = np.zeros((b, window, x.shape[1]))
  ys = np.zeros((b, window, y.shape[1]))
  mask = np.zeros((b, window))
  for i, (lo, hi, first) in enumerate(spans):
    xs[i, :hi - lo] = x[lo:hi]
    ys[i, :hi - lo] = y[lo:hi]
    mask[i, first - lo:hi - lo] = select[first:hi]
  return xs, ys, mask


def _init(key, d: int, h: int, a: int) -> dict:
  """Glorot-uniform input weights, orthogonal recurrent blocks, zero biases, and a small
  output layer (the residual starts near zero: the static map's own answer)."""
  k1, k2, k3 = jax.random.split(key, 3)
  lim = np.sqrt(6.0 / (d + h))
  w = jax.random.uniform(k1, (3 * h, d), jnp.float64, -lim, lim)
  u = jnp.concatenate([jnp.linalg.qr(jax.random.normal(k, (h, h), jnp.float64))[0]
                       for k in jax.random.split(k2, 3)])
  v = 0.1 * jax.random.normal(k3, (a, h), jnp.float64) / np.sqrt(h)
  return {"w": w, "u": u, "b": jnp.zeros(3 * h), "c": jnp.zeros(h), "v": v,
          "v0": jnp.zeros(a)}


@mlp.float64
def train(x: np.ndarray, y: np.ndarray, runs: list[tuple[int, int]], select: np.ndarray,
          config: GRUConfig = GRUConfig(), seed: int = 0,
          progress: Optional[Callable[[int, int], None]] = None) -> tuple[GRU, TrainResult]:
  """Fits the cell to targets y (N, A) from inputs x (N, D).

  Args:
    x, y: whole recordings in time order.  runs: [(start, stop)] of each recording (or
      episode): no window crosses one.  select: (N,) bool, the samples the loss reads.
    config: settings.  seed: integer driving the held-out recordings, the start point (JAX
      key) and the windows' order.
    progress: called as progress(step, config.steps) at each held-out evaluation, and
      progress(step, step) at an early stop.
  """
  config.validate()
  rng = np.random.default_rng(np.random.SeedSequence([seed, 7]))
  fit_rows, val_rows, val_units = _held_out_units(len(x), runs, select, config, rng)
  x_mean, x_scale = x[fit_rows].mean(axis=0), x[fit_rows].std(axis=0)
  x_scale = np.where(x_scale > 0, x_scale, 1.0)
  y_mean, y_scale = y[fit_rows].mean(axis=0), y[fit_rows].std(axis=0)
  y_scale = np.where(y_scale > 0, y_scale, 1.0)
  xs, ys = (x - x_mean) / x_scale, (y - y_mean) / y_scale
  tr = windows(runs, fit_rows, config.window, config.burn_in)
  va = windows(runs, val_rows, config.window, config.burn_in)
  if not tr or not va:
    raise errors.DataError("no training or no held-out window holds a selected sample")
  bsz = min(config.batch, len(tr))
  batches = _padded(_pack_windows(xs, ys, fit_rows, tr, config.window), bsz)
  held = tuple(jnp.asarray(a) for a in _pack_windows(xs, ys, val_rows, va, config.window))
  p = _init(jax.random.key(seed), x.shape[1], config.hidden, y.shape[1])
  run = _adam(p, batches, bsz, held, config, rng, progress)
  net = GRU(*(np.asarray(run["best"][k]) for k in ("w", "u", "b", "c", "v", "v0")),
            x_mean, x_scale, y_mean, y_scale)
  if run["best_check"] == 0:  # no step beat the start held out: the output is exactly 0
    net = dataclasses.replace(net, v=np.zeros_like(net.v), v0=-y_mean / y_scale)
  return net, TrainResult(run["steps"], run["stop"], np.array(run["hist"]),
                          run["best_check"] * config.check, run["seconds"],
                          run["compile_s"], tuple(val_units))


def _held_out_units(n: int, runs, select: np.ndarray, config: GRUConfig, rng):
  """(training rows, held-out rows, the held-out units): whole recordings when there are
  `config.min_recordings`, else contiguous blocks of them."""
  if len(runs) >= config.min_recordings:
    units = list(runs)
  else:  # too few recordings to hold whole ones out: contiguous blocks of them
    units = [(k, min(k + config.block, hi)) for lo, hi in runs
             for k in range(lo, hi, config.block)]
  order = rng.permutation(len(units))
  n_val = min(len(units) - 1, max(1, int(round(config.val_fraction * len(units)))))
  val_units = [units[k] for k in sorted(order[:n_val])]
  held = np.zeros(n, bool)
  for lo, hi in val_units:
    held[lo:hi] = True
  fit_rows, val_rows = select & ~held, select & held
  if not fit_rows.any() or not val_rows.any():
    raise errors.DataError("no selected sample in the training or in the held-out part")
  return fit_rows, val_rows, val_units


def _padded(packed, bsz: int):
  """The windows (x, y, mask) with the last batch filled with unscored windows."""
  tx = packed[0]
  pad = -(-len(tx) // bsz) * bsz - len(tx)
  return tuple(np.concatenate([a, np.zeros((pad,) + a.shape[1:])]) for a in packed)


def _adam(p, batches, bsz: int, held, config: GRUConfig, rng, progress) -> dict:
  """Adam steps over the windows in batches, a new order each pass, until the step cap or
  `patience` held-out checks without a better error; the best weights on the held-out
  windows."""
  tx, ty, tm = batches
  vx, vy, vm = held
  n_batches, lr = len(tx) // bsz, config.learning_rate
  m = jax.tree.map(jnp.zeros_like, p)
  v = jax.tree.map(jnp.zeros_like, p)
  t0 = time.perf_counter()
  jax.block_until_ready(_adam_step(p, m, v, 1.0, lr, tx[:bsz], ty[:bsz], tm[:bsz]))
  hist = [float(_held_out_loss(p, vx, vy, vm))]
  compile_s = time.perf_counter() - t0
  best, best_check, stop = p, 0, mlp.Stop.MAX_EPOCHS
  t1 = time.perf_counter()
  perm = rng.permutation(len(tx))
  for t in range(1, config.steps + 1):
    k = (t - 1) % n_batches
    if k == 0 and t > 1:  # each pass over the windows in a new order
      perm = rng.permutation(len(tx))
    idx = perm[k * bsz:(k + 1) * bsz]
    p, m, v, _ = _adam_step(p, m, v, float(t), lr, tx[idx], ty[idx], tm[idx])
    if t % config.check and t < config.steps:
      continue
    hist.append(float(_held_out_loss(p, vx, vy, vm)))
    if not np.isfinite(hist[-1]):
      raise errors.DataError(f"the recurrent network's held-out error became {hist[-1]} at "
                             f"step {t}: lower its learning_rate ({config.learning_rate:g})")
    if progress:
      progress(t, config.steps)
    if hist[-1] < hist[best_check]:
      best, best_check = p, len(hist) - 1
    elif len(hist) - 1 - best_check >= config.patience:
      stop = mlp.Stop.VALIDATION
      break
  if progress and t < config.steps:
    progress(t, t)
  return {"best": best, "steps": t, "stop": stop, "hist": hist, "best_check": best_check,
          "seconds": time.perf_counter() - t1, "compile_s": compile_s}
