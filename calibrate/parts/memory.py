"""Calibrators that remember: a front end that gives a static estimator the recording's past.

Every estimator of `calibrate.estimators` maps the C counts of one instant to a force, so it
cannot undo what happened before that instant: a die's offset that drifted over minutes, the
rubber's relaxation, the dies' hysteresis. `Memory` turns a recording into features that
carry that past, causally (each sample's features use only that sample and earlier ones of
its own recording), and the static estimator is fitted on them:

- drift tracking (`Tare`): each channel is re-zeroed during unloaded intervals, as users of
  an F/T sensor bias it before contact. A legged robot's foot is unloaded in every swing and
  the CNC lifts the pad between strokes. An interval is unloaded where a linear map of the
  counts (`Memory.detector`) reads a normal force below `Tare.threshold` for 2 `Tare.hold` + 1
  samples in a row, or where a given contact flag says so; through the interval the offset is
  the running mean of its counts from `hold` samples after its start to `hold` samples
  before, less their level at no load.
- history features: each channel's distance from its exponentially filtered value at time
  constants `taus` (x - LP_tau(x), a high-pass), and its first difference. The inverse of a
  Prony relaxation is linear in such filters: for c = (g_inf + g1 tau s / (1 + tau s)) f,
  f = (tau / tau* c + (1 - tau / tau*) LP_tau*(c)) / (g_inf + g1), tau* = tau (g_inf + g1) /
  g_inf, so LS on these features undoes relaxation at the time constants it is given.

Recordings never share a filter state: `segments` labels each sample's recording (or
episode), and every filter starts afresh where the label changes; the tare's offset does
too, unless `sessions` groups segments one sensor read without a reset (the episodes of one
session, through which the drift carries on).
"""

from __future__ import annotations

import dataclasses
from typing import Optional

import numpy as np
from scipy import signal

from calibrate.cexport.emitter import literal
from calibrate.parts import linear
from util import errors


@dataclasses.dataclass(frozen=True)
class Tare:
  """The drift tracker's rule for unloaded intervals.

  Attributes:
    threshold: a sample is unloaded while the detector's normal force (output `axis`, in
      its units, N) is within +-threshold of zero: above what the drift makes it read at no
      load, below the lightest load (the footpad: 10 N, `temporal_calibrators` says why).
    hold: an interval must stay unloaded for 2 hold + 1 samples before the channels are
      re-zeroed (a brief dip through zero while loaded is not an unloaded foot), and the tare
      reads it from `hold` samples after its start to `hold` samples late, so the samples of
      a load still falling as it begins, or rising again as it ends, never enter it.
    axis: the detector's output that is the normal force.
  """
  threshold: float = 3.0
  hold: int = 10
  axis: int = 2

  def validate(self) -> None:
    if not (np.isfinite(self.threshold) and self.threshold > 0):
      raise errors.SettingError(f"tare threshold={self.threshold!r} is out of range: allowed "
                                f"a finite force > 0")
    if not (isinstance(self.hold, (int, np.integer)) and 1 <= self.hold <= 100_000):
      raise errors.SettingError(f"tare hold={self.hold!r} is out of range: integers "
                                f"1..100000 samples")


@dataclasses.dataclass(frozen=True)
class Memory:
  """The temporal front end of an estimator.

  Attributes:
    channels: C, the raw input channels.
    dt: s between samples.
    taus: time constants of the high-pass features, s (empty: none).
    differences: add each channel's first difference (counts per sample).
    tare: the drift tracker's rule (None: no tracking).
    detector: the linear map (counts -> forces) whose normal force the tare rule reads;
      with a contact flag in `features` it is not needed.
    reference: (C,) the channels' counts at no load, which tares restore.
  """
  channels: int
  dt: float
  taus: tuple[float, ...] = ()
  differences: bool = False
  tare: Optional[Tare] = None
  detector: Optional[linear.LinearFit] = None
  reference: Optional[np.ndarray] = None

  @property
  def width(self) -> int:
    """Features per sample: the channels, then C per time constant, then C differences."""
    return self.channels * (1 + len(self.taus) + int(self.differences))

  def names(self, inputs: tuple[str, ...]) -> tuple[str, ...]:
    """Names of the features, from the channels' names."""
    out = list(inputs)
    for tau in self.taus:
      out += [f"{n}-lp{tau:g}s" for n in inputs]
    if self.differences:
      out += [f"d{n}" for n in inputs]
    return tuple(out)

  def validate(self) -> None:
    if not (np.isfinite(self.dt) and self.dt > 0):
      raise errors.SettingError(f"dt={self.dt!r} is out of range: the time between samples, "
                                f"> 0 s")
    for tau in self.taus:
      if not (np.isfinite(tau) and tau > 0):
        raise errors.SettingError(f"time constant {tau!r} is out of range: > 0 s")
    if self.tare is not None:
      self.tare.validate()

  def offsets(self, counts: np.ndarray, segments: Optional[np.ndarray] = None,
              contact: Optional[np.ndarray] = None, sessions: Optional[np.ndarray] = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """(N, C) the tracked offset of every sample (zero without a tare) and (N,) bool, the
    samples whose counts a tare read (taken as unloaded). The tare's state runs through each
    session (`sessions` labels; None: each segment is its own session)."""
    counts = np.asarray(counts, float)
    n = len(counts)
    segments = _sessions_hold_segments(segments, sessions, n)
    out, read = np.zeros_like(counts), np.zeros(n, bool)
    if self.tare is None:
      return out, read
    if contact is None and self.detector is None:
      raise errors.SettingError("a tare needs a contact flag or a detector map")
    if contact is not None:
      contact = np.asarray(contact).astype(bool)
    for lo, hi in _runs(segments if sessions is None else sessions, n):
      self._tare_segment(counts[lo:hi], None if contact is None else contact[lo:hi],
                         out[lo:hi], read[lo:hi])
    return out, read

  def _tare_segment(self, c, contact, out, read) -> None:
    """Fills out (n, C) and read (n,) for one recording, in time order."""
    tare, ref = self.tare, self.reference
    n = len(c)
    offset = np.zeros(self.channels)
    if contact is None:  # the normal force the detector reads from untared counts
      raw = self.detector.predict(c)[:, tare.axis]
      # the linear map reads F(c - o) = F(c) - unit @ o (a dropped channel: scale 0, unit 0)
      d = self.detector
      unit = np.divide(d.coef[:, tare.axis], d.scale, out=np.zeros(self.channels),
                       where=d.scale > 0)
    start = 0
    while start < n:
      if contact is None:
        free = np.abs(raw[start:] - unit @ offset) < tare.threshold
      else:
        free = ~contact[start:]
      h = tare.hold
      lo, hi = _first_run(free, 2 * h + 1)
      if lo is None:
        out[start:] = offset
        return
      lo, hi = lo + start, hi + start
      # causal, and blind to the interval's first and last `hold` samples: the offset at
      # sample n is the mean of the counts from `hold` after the interval's start to
      # n - hold, so neither a load still falling through the threshold as the interval
      # begins nor one rising back through it as it ends enters the tare
      first = lo + 2 * h
      out[start:first] = offset
      running = np.cumsum(c[lo + h:hi - h], axis=0) / np.arange(1, hi - lo - 2 * h + 1)[:, None]
      out[first:hi] = running - ref
      read[lo + h:hi - h] = True
      offset = out[hi - 1].copy()
      start = hi

  def features(self, counts: np.ndarray, segments: Optional[np.ndarray] = None,
               contact: Optional[np.ndarray] = None, sessions: Optional[np.ndarray] = None
               ) -> np.ndarray:
    """(N, width) features of (N, C) counts in time order; `segments` (N,) labels each
    sample's recording or episode (None: one), where the filters start afresh; `contact`
    (N,) a contact flag for the tare (None: the detector decides); `sessions` (N,) labels
    the runs of segments one sensor read without a reset (power-up), through which the
    tare's offset carries, as the drift does (None: each segment its own session)."""
    counts = np.asarray(counts, float)
    if counts.ndim != 2 or counts.shape[1] != self.channels:
      raise errors.DataError(f"counts have shape {counts.shape}: expected (N, {self.channels})")
    if segments is not None and len(segments) != len(counts):
      raise errors.DataError(f"segments has {len(segments)} labels for {len(counts)} samples")
    x = counts - self.offsets(counts, segments, contact, sessions)[0]
    segments = _sessions_hold_segments(segments, sessions, len(x))
    parts = [x]
    runs = _runs(segments, len(x))
    for tau in self.taus:
      a = np.exp(-self.dt / tau)
      lp = np.empty_like(x)
      for lo, hi in runs:  # y[0] = x[0]: each recording starts at rest
        lp[lo:hi] = signal.lfilter([1.0 - a], [1.0, -a], x[lo:hi], axis=0,
                                   zi=a * x[lo:lo + 1])[0]
      parts.append(x - lp)
    if self.differences:
      d = np.zeros_like(x)
      for lo, hi in runs:
        d[lo + 1:hi] = np.diff(x[lo:hi], axis=0)
      parts.append(d)
    return np.concatenate(parts, axis=1)

  NAME = "memory"

  def children(self) -> dict:
    return {}

  def settings(self) -> dict:
    """Its JSON-able settings (kept in `Info.settings` and in the file)."""
    meta = {"channels": self.channels, "dt": self.dt, "taus": list(self.taus),
            "differences": self.differences}
    if self.tare is not None:
      meta["tare"] = dataclasses.asdict(self.tare)
      if self.detector is not None:
        meta["detector_rank"] = self.detector.rank
    return meta

  def leaves(self) -> tuple[dict, dict]:
    arrays = {}
    if self.tare is not None:
      arrays["reference"] = self.reference
      if self.detector is not None:
        for f in ("mean", "scale", "coef", "bias"):
          arrays[f"detector_{f}"] = getattr(self.detector, f)
    return arrays, self.settings()

  @classmethod
  def from_leaves(cls, spec: dict, arrays: dict, children=None) -> "Memory":
    tare = detector = reference = None
    if "tare" in spec:
      tare = Tare(**spec["tare"])
      reference = arrays["reference"]
      if "detector_coef" in arrays:
        detector = linear.LinearFit.from_leaves(
            {"rank": spec["detector_rank"], "degree": 1},
            {f: arrays[f"detector_{f}"] for f in ("mean", "scale", "coef", "bias")})
    mem = cls(int(spec["channels"]), float(spec["dt"]), tuple(map(float, spec["taus"])),
              bool(spec["differences"]), tare, detector, reference)
    mem.validate()
    if reference is not None and reference.shape != (mem.channels,):
      raise ValueError("the tare's reference does not fit the channels")
    if detector is not None and detector.n_inputs != mem.channels:
      raise ValueError("the tare's detector does not fit the channels")
    return mem

  def _emit_tare(self, em, raw: str) -> list[str]:
    """The drift tare's state machine in C (as `offsets` runs it), its state in statics that
    estimate_reset() clears."""
    c = self.channels
    if self.detector is None:
      raise errors.SettingError("this estimator tares by a contact flag, which the C export "
                                "does not read: fit it with a tare from the counts "
                                "(--track-drift NEWTONS)")
    tr, d = self.tare, self.detector
    ax, hold = tr.axis, int(tr.hold)
    inv = np.where(d.scale > 0, 1.0 / np.where(d.scale > 0, d.scale, 1.0), 0.0)
    unit = em.array("TARE_UNIT", d.coef[:, ax] * inv)
    dmean, ref = em.array("TARE_DET_MEAN", d.mean), em.array("TARE_REF", self.reference)
    em.state += [f"static float tare_judge[{c}], tare_now[{c}], tare_sum[{c}];",
                 f"static float tare_ring[{hold}][{c}];", "static int tare_run, tare_n;"]
    em.session_resets += [f"  for (int i = 0; i < {c}; ++i) tare_judge[i] = tare_now[i] "
                          f"= tare_sum[i] = 0.0f;", "  tare_run = tare_n = 0;"]
    em.macs += 3 * c + 2
    return [
        "  { /* drift tracking: unloaded while the detector's normal force stays within",
        f"     * +-{tr.threshold:g} for {2 * hold + 1} samples; then the offset is the mean of "
        "the", f"     * interval's counts from {hold} samples after its start to {hold} "
        "samples back,", "     * less their level at no load */",
        "    for (int pass = 0; pass < 2; ++pass) {",
        f"      float fz = {literal(d.bias[ax])};",
        f"      for (int i = 0; i < {c}; ++i) fz += {unit}[i] * ({raw}[i] - {dmean}[i] - "
        "tare_judge[i]);",
        f"      if (fabsf(fz) < {literal(tr.threshold)}) {{",
        f"        float *slot = tare_ring[tare_run % {hold}];",
        f"        if (tare_run >= {2 * hold}) {{  /* the sample {hold} back, if {hold} "
        "into the interval */",
        f"          for (int i = 0; i < {c}; ++i) tare_sum[i] += slot[i];",
        "          ++tare_n;",
        "        }",
        f"        for (int i = 0; i < {c}; ++i) slot[i] = {raw}[i] - {ref}[i];",
        "        ++tare_run;",
        "        if (tare_n > 0)",
        f"          for (int i = 0; i < {c}; ++i) tare_now[i] = tare_sum[i] / (float)tare_n;",
        "        break;",
        "      }",
        "      int ended = tare_n > 0;",
        "      tare_run = tare_n = 0;",
        f"      for (int i = 0; i < {c}; ++i) tare_sum[i] = 0.0f;",
        "      if (!ended) break;",
        "      /* an interval ended: this sample is judged again against its offset */",
        f"      for (int i = 0; i < {c}; ++i) tare_judge[i] = tare_now[i];",
        "    }",
        "  }"]

  def emit_front(self, em, raw: str) -> list[str]:
    """C lines that turn this sample's inputs raw[] into the front end's features x[]
    (`calibrate.parts.memory.Memory.features`, streamed): the tare's state machine, then each
    channel's high-pass at every time constant and its first difference. The state lives
    in static variables that `estimate_reset` sets to a recording's start."""
    c, t = self.channels, len(self.taus)
    lines = self._emit_tare(em, raw) if self.tare is not None else []
    now = "tare_now[i]" if self.tare is not None else "0.0f"
    if not (t or self.differences):  # the tared counts alone
      em.macs += c
      return lines + [f"  for (int i = 0; i < {c}; ++i) x[i] = {raw}[i] - {now};"]
    em.state += [f"static float mem_raw[{c}], mem_tare[{c}];", "static int mem_fresh = 1;"]
    em.resets.append("  mem_fresh = 1;")
    em.macs += 2 * c  # the step and the tared value of each channel
    if t:
      alphas = em.array("MEM_ALPHA", np.exp(-self.dt / np.asarray(self.taus)))
      em.state.append(f"static float mem_hp[{t}][{c}];")
      em.macs += t * c
    # the step dx from the raw step (exact for integer counts) less the offset's step: the
    # high-passes and differences in float32 lose nothing to the counts' level (~2,000)
    lines += [f"  for (int i = 0; i < {c}; ++i) {{",
              f"    float dx = mem_fresh ? 0.0f : ({raw}[i] - mem_raw[i]) - ({now} - "
                   "mem_tare[i]);",
              f"    x[i] = {raw}[i] - {now};"]
    if t:  # x - LP_tau(x) kept directly: hp = a (hp + dx), 0 at a recording's start
      lines += [f"    for (int k = 0; k < {t}; ++k) {{",
                f"      mem_hp[k][i] = mem_fresh ? 0.0f : {alphas}[k] * (mem_hp[k][i] + dx);",
                f"      x[{c} * (1 + k) + i] = mem_hp[k][i];",
                "    }"]
    if self.differences:
      lines.append(f"    x[{c * (1 + t)} + i] = dx;")
    lines += [f"    mem_raw[i] = {raw}[i];", f"    mem_tare[i] = {now};", "  }",
              "  mem_fresh = 0;"]
    em.stack = max(em.stack, 4 * self.width)
    return lines


def _runs(segments: Optional[np.ndarray], n: int) -> list[tuple[int, int]]:
  """[(start, stop)] of the contiguous runs of equal labels (one run without labels)."""
  if segments is None or n == 0:
    return [(0, n)]
  s = np.asarray(segments)
  cut = np.flatnonzero(s[1:] != s[:-1]) + 1
  edges = np.concatenate([[0], cut, [n]])
  return list(zip(edges[:-1].tolist(), edges[1:].tolist()))


def _sessions_hold_segments(segments, sessions, n: int):
  """The segments, checked to lie each inside one session (with sessions and no segments,
  the sessions are the segments)."""
  if sessions is None:
    return segments
  if len(sessions) != n:
    raise errors.DataError(f"sessions has {len(sessions)} labels for {n} samples")
  if segments is None:
    return sessions
  cuts = {lo for lo, _ in _runs(sessions, n)}
  if not cuts <= {lo for lo, _ in _runs(segments, n)}:
    raise errors.DataError("a segment crosses from one session into the next: a session is "
                           "a run of whole segments")
  return segments


def _first_run(mask: np.ndarray, length: int) -> tuple[Optional[int], Optional[int]]:
  """(start, stop) of the first run of True at least `length` long, else (None, None)."""
  m = np.concatenate([[False], mask, [False]])
  edges = np.flatnonzero(m[1:] != m[:-1])
  starts, stops = edges[::2], edges[1::2]
  long = np.flatnonzero(stops - starts >= length)
  if not len(long):
    return None, None
  return int(starts[long[0]]), int(stops[long[0]])


def reference_counts(counts: np.ndarray, free: np.ndarray) -> np.ndarray:
  """(C,) the channels' median counts over unloaded samples `free` (N,) bool."""
  if not free.any():
    raise errors.DataError("no unloaded sample to take the counts at no load from: the tare "
                           "needs the recordings to hold unloaded intervals (or a contact "
                           "flag)")
  return np.median(np.asarray(counts, float)[free], axis=0)
