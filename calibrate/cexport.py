"""A fitted estimator as dependency-free C99 for the sensor's microcontroller.

`write(est, out_dir)` writes `estimator.h` and `estimator.c`: float32 weights in `static
const` arrays (flash) and one function

    void estimate(const uint16_t counts[ESTIMATOR_INPUTS], float out[ESTIMATOR_OUTPUTS]);

(or `const float inputs[...]` when the estimator was fitted on inputs that are not integers
in 0..65535: volts after a tare, signed microtesla) that computes what `Estimator.predict`
computes in float64 (LS, POLY, LSANN, NN and ensembles, whose members it averages), with only <stdint.h> and <math.h> (tanhf). It returns
a `Report`: multiply-adds, tanh calls, bytes of flash and of stack, against the budget of a
1 kHz loop on the footpad's microcontroller.

The budget (`Budget`): the LSANN paper's footpad reads its ADC with an NXP LPC1768, an ARM
Cortex-M3 (paper Sec. II), run at 96 MHz on its mbed board (the LPC1768's limit is 100 MHz;
512 kB flash, 64 kB SRAM: NXP's LPC1769/68/67/66/65/64/63 datasheet). The Cortex-M3 has no
floating-point unit, so every float operation is a library call. Measured here by counting
executed instructions in qemu-arm (Debian's gcc-arm-linux-gnueabi, -O2 -mthumb
-mfloat-abi=soft, libgcc's soft-float and glibc's tanhf; ARMv7 Thumb-2, the M3's instruction
set, the library routines in ARM mode): 74 instructions per float multiply-add, about 1,700
per tanhf; a 10-hidden-unit LSANN estimate 25,400 instructions (50,795 for a mean of two).
The M3 takes 1 to 1.5 cycles per instruction on such code (assumed: loads and taken branches
take 2-3 cycles, the rest 1), so the report gives a range of cycles per estimate beside the
96,000 a 1 kHz loop has.
"""

from __future__ import annotations

import dataclasses
import pathlib
from typing import Optional
import re

import numpy as np

from util import errors, files


# instructions of one Q16 multiply-add (int64 accumulate) and of one table tanh (`fixed_point`),
# measured as the float ones (module docstring): qemu-arm runs of the fixed-point GRU at 4, 8
# and 16 hidden units (5,020, 6,339 and 10,047 instructions per estimate), solved for the
# two per-operation counts and the fixed rest
FIXED_MAC = 3.7
FIXED_TANH = 41.0


@dataclasses.dataclass(frozen=True)
class Budget:
  """The target: clock, memories and the assumed cost of soft-float operations.

  Attributes:
    clock_hz: 96 MHz (mbed LPC1768).  rate_hz: estimates per second (the footpad's 1 kHz).
    flash_bytes, ram_bytes: 512 kB and 64 kB (LPC1768 datasheet).
    mac_cycles: (low, high) cycles of one soft-float multiply and add: 74 instructions
      (measured, module docstring) at 1 to 1.5 cycles each.
    tanh_cycles: (low, high) cycles of one tanhf: 1,700 instructions (measured) at 1 to 1.5
      cycles each.
    fixed_mac_cycles, fixed_tanh_cycles: the same for the fixed-point variant's Q16
      multiply-add and table tanh (`FIXED_MAC`, `FIXED_TANH`).
  """
  clock_hz: float = 96e6
  rate_hz: float = 1000.0
  flash_bytes: int = 512 * 1024
  ram_bytes: int = 64 * 1024
  mac_cycles: tuple[float, float] = (74.0, 111.0)
  tanh_cycles: tuple[float, float] = (1700.0, 2550.0)
  fixed_mac_cycles: tuple[float, float] = (FIXED_MAC, 1.5 * FIXED_MAC)
  fixed_tanh_cycles: tuple[float, float] = (FIXED_TANH, 1.5 * FIXED_TANH)


@dataclasses.dataclass(frozen=True)
class Report:
  """What the exported estimator costs per call.

  Attributes:
    multiply_adds, tanh: operations per estimate.
    flash_bytes: the weights (float32).  stack_bytes: the largest working arrays.
    cycles: (low, high) per estimate from `Budget`'s ranges.  budget: the target.
    files: the paths written.
  """
  multiply_adds: int
  tanh: int
  flash_bytes: int
  stack_bytes: int
  cycles: tuple[float, float]
  budget: Budget
  files: tuple[str, ...]
  fixed_multiply_adds: int = 0
  fixed_tanh: int = 0

  def text(self) -> str:
    b = self.budget
    per_loop = b.clock_hz / b.rate_hz
    lo, hi = self.cycles
    return (f"wrote {', '.join(self.files)}\n"
            f"per estimate: {self.multiply_adds} multiply-adds, {self.tanh} tanhf; weights "
            f"{self.flash_bytes:,} bytes of flash ({self.flash_bytes / b.flash_bytes:.2%} of "
            f"{b.flash_bytes // 1024} kB), {self.stack_bytes} bytes of stack "
            f"({self.stack_bytes / b.ram_bytes:.2%} of {b.ram_bytes // 1024} kB)\n"
            f"on a {b.clock_hz / 1e6:g} MHz Cortex-M3 without FPU (soft float: "
            f"{b.mac_cycles[0]:g}-{b.mac_cycles[1]:g} cycles per multiply-add, "
            f"{b.tanh_cycles[0]:g}-{b.tanh_cycles[1]:g} per tanhf"
            + (f"; fixed point: {self.fixed_multiply_adds} Q16 multiply-adds and "
               f"{self.fixed_tanh} table tanh at {b.fixed_mac_cycles[0]:g} and "
               f"{b.fixed_tanh_cycles[0]:g}+ cycles" if self.fixed_multiply_adds else "")
            + f"): {lo:,.0f}-{hi:,.0f} "
            f"cycles, {lo / per_loop:.0%}-{hi / per_loop:.0%} of a {b.rate_hz:g} Hz loop's "
            f"{per_loop:,.0f}")


def _floats(a: np.ndarray) -> str:
  flat = np.asarray(a, np.float32).ravel()
  return ", ".join(_literal(v) for v in flat)


def _literal(v: float) -> str:
  """A float32 C literal that reads back to the same float (9 significant digits)."""
  text = f"{float(np.float32(v)):.9g}"
  return text + ("f" if any(ch in text for ch in ".eEn") else ".0f")


class _Writer:
  """Collects the constant arrays and the code of one estimator, member by member."""

  def __init__(self, fixed_point: bool = False):
    self.fixed = fixed_point
    self.fixed_macs = 0
    self.fixed_tanh = 0
    self.arrays: list[str] = []
    self.code: list[str] = []
    self.flash = 0
    self.macs = 0
    self.tanh = 0
    self.stack = 0
    self.state: list[str] = []  # static variables a temporal estimator carries between calls
    self.resets: list[str] = []  # estimate_restart(): a segment's (episode's) start
    self.session_resets: list[str] = []  # estimate_reset() adds these: a session's start

  def array(self, name: str, a: np.ndarray) -> str:
    a = np.asarray(a, np.float64)
    self.arrays.append(f"static const float {name}[{a.size}] = {{{_floats(a)}}};")
    self.flash += 4 * a.size
    return name

  def linear(self, fit, tag: str, c: int, acc: str = "acc") -> None:
    inv = np.where(fit.scale > 0, 1.0 / np.where(fit.scale > 0, fit.scale, 1.0), 0.0)
    mean, scale = self.array(f"{tag}_MEAN", fit.mean), self.array(f"{tag}_INV_SCALE", inv)
    coef = self.array(f"{tag}_COEF", fit.coef)  # (C * degree, A), row-major
    bias = self.array(f"{tag}_BIAS", fit.bias)
    a = fit.coef.shape[1]
    self.macs += fit.coef.size + c * (fit.degree - 1)
    self.stack = max(self.stack, 4 * c)
    self.code += [
        f"  {{ /* {'linear' if fit.degree == 1 else f'polynomial, degree {fit.degree}'} */",
        f"    float z[{c}];",
        f"    for (int i = 0; i < {c}; ++i) z[i] = (x[i] - {mean}[i]) * {scale}[i];",
        f"    for (int j = 0; j < {a}; ++j) {acc}[j] += {bias}[j];",
        f"    for (int i = 0; i < {c}; ++i) {{",
        "      float p = z[i];",
        f"      for (int d = 0; d < {fit.degree}; ++d) {{",
        f"        const float *row = &{coef}[(d * {c} + i) * {a}];",
        f"        for (int j = 0; j < {a}; ++j) {acc}[j] += row[j] * p;",
        "        p *= z[i];",
        "      }",
        "    }",
        "  }"]

  def poly(self, fit, tag: str, c: int) -> None:
    """A polynomial with cross terms (`calibrate.poly.PolyFit`), continued along its tangent
    plane beyond the training box, as `PolyFit.predict` does."""
    t, a = fit.coef.shape
    mean, inv = self.array(f"{tag}_MEAN", fit.mean), self.array(f"{tag}_INV_SCALE", 1 / fit.scale)
    lo, hi = self.array(f"{tag}_LO", fit.lo), self.array(f"{tag}_HI", fit.hi)
    coef, bias = self.array(f"{tag}_COEF", fit.coef), self.array(f"{tag}_BIAS", fit.bias)
    pw = f"{tag}_POW"
    self.arrays.append(f"static const unsigned char {pw}[{fit.powers.size}] = "
                       f"{{{', '.join(str(int(v)) for v in fit.powers.ravel())}}};")
    self.flash += fit.powers.size
    self.macs += t * (fit.degree + a)
    self.stack = max(self.stack, 12 * c)
    self.code += [
        f"  {{ /* polynomial with cross terms, degree {fit.degree}, {t} terms; linear beyond "
        f"the training box */",
        f"    float z[{c}], zc[{c}], dz[{c}];",
        "    int outside = 0;",
        f"    for (int i = 0; i < {c}; ++i) {{",
        f"      z[i] = (x[i] - {mean}[i]) * {inv}[i];",
        f"      zc[i] = z[i] < {lo}[i] ? {lo}[i] : (z[i] > {hi}[i] ? {hi}[i] : z[i]);",
        "      dz[i] = z[i] - zc[i];",
        "      outside |= dz[i] != 0.0f;",
        "    }",
        f"    for (int j = 0; j < {a}; ++j) acc[j] += {bias}[j];",
        f"    for (int t = 0; t < {t}; ++t) {{",
        f"      const unsigned char *e = &{pw}[t * {c}];",
        f"      const float *row = &{coef}[t * {a}];",
        "      float m = 1.0f;",
        f"      for (int i = 0; i < {c}; ++i)",
        "        for (int k = 0; k < e[i]; ++k) m *= zc[i];",
        f"      for (int j = 0; j < {a}; ++j) acc[j] += row[j] * m;",
        "      if (!outside) continue;",
        f"      for (int v = 0; v < {c}; ++v) {{ /* the tangent plane's slope along z[v] */",
        "        if (e[v] == 0 || dz[v] == 0.0f) continue;",
        "        float g = (float)e[v];",
        f"        for (int i = 0; i < {c}; ++i)",
        "          for (int k = 0; k < e[i] - (i == v); ++k) g *= zc[i];",
        f"        for (int j = 0; j < {a}; ++j) acc[j] += row[j] * g * dz[v];",
        "      }",
        "    }",
        "  }"]

  def network(self, net, tag: str) -> None:
    h, d1 = net.w1.shape
    c, a = d1 - 1, net.w2.shape[0]
    xhalf, xmid = net.x_scale._half()
    yhalf, ymid = net.y_scale._half()
    xm, xi = self.array(f"{tag}_XMID", xmid), self.array(f"{tag}_XINV", 1.0 / xhalf)
    w1, w2 = self.array(f"{tag}_W1", net.w1), self.array(f"{tag}_W2", net.w2)
    ym, yh = self.array(f"{tag}_YMID", ymid), self.array(f"{tag}_YHALF", yhalf)
    self.macs += h * d1 + a * (h + 1) + c + a
    self.tanh += h
    self.stack = max(self.stack, 4 * (c + h))
    self.code += [
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
        f"      acc[j] += v * {yh}[j] + {ym}[j];",
        "    }",
        "  }"]


  def ints(self, name: str, a: np.ndarray) -> str:
    """A Q16 (value x 65,536, rounded) int32_t array."""
    q = np.clip(np.round(np.asarray(a, np.float64).ravel() * 65536.0), -2 ** 31, 2 ** 31 - 1)
    self.arrays.append(f"static const int32_t {name}[{q.size}] = "
                       f"{{{', '.join(str(int(v)) for v in q)}}};")
    self.flash += 4 * q.size
    return name

  def _gru_arrays(self, rnn, tag: str, weights, prefix: str) -> list[str]:
    """The names of a GRU's arrays: its input and output scalings in float, its weights
    written by `weights` (`array`, or `ints` for Q16) under names with `prefix`."""
    names = [self.array(f"{tag}_XMEAN", rnn.x_mean), self.array(f"{tag}_XINV", 1 / rnn.x_scale)]
    names += [weights(f"{tag}_{prefix}{f.upper()}", getattr(rnn, f))
              for f in ("w", "u", "b", "c", "v", "v0")]
    return names + [self.array(f"{tag}_YMEAN", rnn.y_mean),
                    self.array(f"{tag}_YSCALE", rnn.y_scale)]

  def gru_fixed(self, rnn, tag: str) -> None:
    """The recurrent network in Q16 fixed point (int32 values, int64 sums; tanh from a
    513-entry table at steps of 1/64, linear between: within 2.3e-5 of tanh): the gates and
    the state, which in float cost the Cortex-M3 its soft-float tanhf calls. Inputs are
    standardised and the output scaled in float."""
    h, d, a = rnn.hidden, rnn.inputs, rnn.v.shape[0]
    if "TANH_Q16" not in "".join(self.arrays):
      self.ints("TANH_Q16", np.tanh(np.arange(513) / 64.0))
      self.state += [
          "static int32_t tanh_q16(int32_t v) {  /* Q16 in and out: the table, linear between */",
          "  int32_t m = v < 0 ? -v : v, y;",
          "  if (m >= (8 << 16)) y = 65536;",
          "  else {",
          "    int32_t k = m >> 10, f = m & 1023;",
          "    y = TANH_Q16[k] + (((TANH_Q16[k + 1] - TANH_Q16[k]) * f) >> 10);",
          "  }",
          "  return v < 0 ? -y : y;",
          "}"]
    xm, xi, w, u, b, c, v, v0, ym, ys = self._gru_arrays(rnn, tag, self.ints, "Q")
    self.state.append(f"static int32_t {tag}_HQ[{h}];")
    self.resets.append(f"  for (int k = 0; k < {h}; ++k) {tag}_HQ[k] = 0;")
    # the float standardisation and output scaling; a float-to-int conversion (lrintf) costs
    # about two multiply-adds (measured with the rest: 160 instructions)
    self.macs += 3 * d + 2 * a
    self.fixed_macs += 3 * h * (d + h) + 2 * h + a * h
    self.fixed_tanh += 3 * h
    self.stack = max(self.stack, 4 * (d + 4 * h))
    self.code += [
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
        f"      acc[j] += (float)(e >> 16) * {_literal(1 / 65536)} * {ys}[j] + {ym}[j];",
        "    }",
        "  }"]

  def gru(self, rnn, tag: str) -> None:
    """The recurrent network (`calibrate.recurrent.GRU`) on the first D of x[], its state in
    a static array that `estimate_reset` zeroes; sigmoid(v) as 0.5 + 0.5 tanhf(v / 2)."""
    if self.fixed:
      return self.gru_fixed(rnn, tag)
    h, d, a = rnn.hidden, rnn.inputs, rnn.v.shape[0]
    xm, xi, w, u, b, c, v, v0, ym, ys = self._gru_arrays(rnn, tag, self.array, "")
    self.state.append(f"static float {tag}_H[{h}];")
    self.resets.append(f"  for (int k = 0; k < {h}; ++k) {tag}_H[k] = 0.0f;")
    self.macs += d + 3 * h * (d + h) + 6 * h + a * (h + 1)
    self.tanh += 3 * h
    self.stack = max(self.stack, 4 * (d + 4 * h))
    self.code += [
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
        f"      acc[j] += e * {ys}[j] + {ym}[j];",
        "    }",
        "  }"]

  def memory(self, mem, raw: str) -> list[str]:
    """C lines that turn this sample's inputs raw[] into the front end's features x[]
    (`calibrate.temporal.Memory.features`, streamed): the tare's state machine, then each
    channel's high-pass at every time constant and its first difference. The state lives
    in static variables that `estimate_reset` sets to a recording's start."""
    c, t = mem.channels, len(mem.taus)
    lines = []
    if mem.tare is not None:
      if mem.detector is None:
        raise errors.SettingError("this estimator tares by a contact flag, which the C export "
                                  "does not read: fit it with a tare from the counts "
                                  "(--track-drift NEWTONS)")
      tr, d = mem.tare, mem.detector
      ax, hold = tr.axis, int(tr.hold)
      inv = np.where(d.scale > 0, 1.0 / np.where(d.scale > 0, d.scale, 1.0), 0.0)
      unit = self.array("TARE_UNIT", d.coef[:, ax] * inv)
      dmean, ref = self.array("TARE_DET_MEAN", d.mean), self.array("TARE_REF", mem.reference)
      self.state += [f"static float tare_judge[{c}], tare_now[{c}], tare_sum[{c}];",
                     f"static float tare_ring[{hold}][{c}];", "static int tare_run, tare_n;"]
      self.session_resets += [f"  for (int i = 0; i < {c}; ++i) tare_judge[i] = tare_now[i] "
                              f"= tare_sum[i] = 0.0f;", "  tare_run = tare_n = 0;"]
      self.macs += 3 * c + 2
      lines += [
          "  { /* drift tracking: unloaded while the detector's normal force stays within",
          f"     * +-{tr.threshold:g} for {2 * hold + 1} samples; then the offset is the mean of "
          "the", f"     * interval's counts from {hold} samples after its start to {hold} "
          "samples back,", "     * less their level at no load */",
          "    for (int pass = 0; pass < 2; ++pass) {",
          f"      float fz = {_literal(d.bias[ax])};",
          f"      for (int i = 0; i < {c}; ++i) fz += {unit}[i] * ({raw}[i] - {dmean}[i] - "
          "tare_judge[i]);",
          f"      if (fabsf(fz) < {_literal(tr.threshold)}) {{",
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
          f"      tare_run = tare_n = 0;",
          f"      for (int i = 0; i < {c}; ++i) tare_sum[i] = 0.0f;",
          "      if (!ended) break;",
          "      /* an interval ended: this sample is judged again against its offset */",
          f"      for (int i = 0; i < {c}; ++i) tare_judge[i] = tare_now[i];",
          "    }",
          "  }"]
      now = "tare_now[i]"
    else:
      now = "0.0f"
    if not (t or mem.differences):  # the tared counts alone
      self.macs += c
      return lines + [f"  for (int i = 0; i < {c}; ++i) x[i] = {raw}[i] - {now};"]
    self.state += [f"static float mem_raw[{c}], mem_tare[{c}];", "static int mem_fresh = 1;"]
    self.resets.append("  mem_fresh = 1;")
    self.macs += 2 * c  # the step and the tared value of each channel
    if t:
      alphas = self.array("MEM_ALPHA", np.exp(-mem.dt / np.asarray(mem.taus)))
      self.state.append(f"static float mem_hp[{t}][{c}];")
      self.macs += t * c
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
    if mem.differences:
      lines.append(f"    x[{c * (1 + t)} + i] = dx;")
    lines += [f"    mem_raw[i] = {raw}[i];", f"    mem_tare[i] = {now};", "  }",
              "  mem_fresh = 0;"]
    self.stack = max(self.stack, 4 * mem.width)
    return lines


def comment_text(name: str) -> str:
  """A column name as it may stand inside a C block comment: ASCII only (other characters
  as \\uXXXX escapes), no control characters, and no `*/` or `/*` that would close or nest
  the comment."""
  text = "".join(ch if " " <= ch <= "~" else f"\\u{ord(ch):04x}" for ch in str(name))
  while "*/" in text or "/*" in text:
    text = text.replace("*/", "* /").replace("/*", "/ *")
  return text


def identifiers(names) -> list[str]:
  """C identifiers (upper case, [A-Z0-9_]) for column names, unique: characters outside
  them become `_`, a name that starts with a digit or ends up empty gets a `C` in front,
  and a name that repeats an earlier one gets its position appended."""
  out: list[str] = []
  for k, name in enumerate(names):
    ident = re.sub(r"[^A-Z0-9_]", "_", str(name).upper()) or "C"
    ident = "C" + ident if ident[0].isdigit() else ident
    while ident in out:
      ident = f"{ident}_{k}"
    out.append(ident)
  return out


def _tare(est) -> Optional[dict]:
  """The tare rule the estimator was fitted with (`calibrate.prepare`), or None."""
  if est.info is None:
    return None
  return (est.info.settings.get("prepare") or {}).get("tare")


def integer_inputs(est) -> bool:
  """Whether the estimator's inputs were ADC counts: integers in 0..65535 when it was fitted
  (`fit` records it; an older file without the record: its training range decides). With a
  tare, the raw inputs before it decide: the C function tares them itself."""
  info = est.info
  if info is None:
    return True
  prepared = info.settings.get("prepare") or {}
  known = prepared.get("raw_integer_inputs") if prepared.get("tare") else \
      info.settings.get("integer_inputs")
  if known is not None:
    return bool(known)
  return bool((info.input_lo >= 0).all() and (info.input_hi <= 65535).all()
              and all(u == "counts" for u in info.input_units))


def _outputs(est) -> int:
  one = est.parts[0] if est.parts else est.members[0] if est.members else est
  if one.parts or one.members:
    return _outputs(one)
  return (one.poly.coef.shape[1] if one.poly is not None else
          one.linear.coef.shape[1] if one.linear is not None else one.net.w2.shape[0])


def _compute(est, w: _Writer, c: int, a: int, dest: str, prefix: str = "") -> list[str]:
  """C lines that compute `est` (one estimator or an ensemble) from x[] into dest[a]."""
  from calibrate import estimators
  members = est.members or (est,)
  before = len(w.code)
  # an ensemble's members share the linear stage they were fitted with: computed once
  shared = len(members) > 1 and all(m.linear is not None for m in members) and all(
      all(np.array_equal(getattr(m.linear, f), getattr(members[0].linear, f))
          for f in ("mean", "scale", "coef", "bias")) for m in members[1:])
  if shared:
    w.linear(members[0].linear, f"{prefix}SHARED_LIN", c, acc="lin")
  for k, m in enumerate(members):
    tag = f"{prefix}M{k}"
    if m.poly is not None:
      w.poly(m.poly, f"{tag}_POLY", c)
    elif m.kind is not estimators.Kind.NN and not shared:
      w.linear(m.linear, f"{tag}_LIN", c)
    if m.kind in (estimators.Kind.NN, estimators.Kind.LSANN):
      w.network(m.net, f"{tag}_NET")
    if m.rnn is not None:
      w.gru(m.rnn, f"{tag}_GRU")
  code, w.code = w.code[before:], w.code[:before]
  if not code:
    raise errors.DataError("the estimator has neither a linear stage nor a network to export")
  w.macs += a * len(members)
  return ([f"  {{ /* {est.kind.value}" + (f", mean of {len(members)}" if est.members else "")
           + " */", f"    float acc[{a}], lin[{a}];",
           f"    for (int j = 0; j < {a}; ++j) {{ acc[j] = 0.0f; lin[j] = 0.0f; }}"]
          + ["  " + line for line in code]
          + [f"    for (int j = 0; j < {a}; ++j) {dest}[j] = lin[j] + acc[j] * "
             f"{_literal(1.0 / len(members))};", "  }"])


def _tare_code(tare: dict, c: int, counts: bool, info) -> tuple[list[str], list[str]]:
  """(header lines, source lines) of the tare the estimator was fitted with: the caller
  feeds the unloaded samples (the rule is in the comment), the offsets are their per-channel
  median, as `predict` takes them, and `estimate` subtracts them."""
  kind = "const uint16_t counts" if counts else "const float inputs"
  rule = (f"the first {tare['seconds']:g} s of each recording" if tare.get("seconds")
          is not None else f"the samples where {comment_text(tare['flag'])} is 0")
  rate = info.settings.get("prepare", {}).get("sample_rate")
  size = 256 if tare.get("seconds") is None or not rate else \
      max(16, int(np.ceil(tare["seconds"] * rate)) + 8)
  header = [
      f"/* Tare (fit --tare): feed {rule} (unloaded) to estimate_tare_add, then call",
      " * estimate_tare_end; estimate() then subtracts each input's median over them (up to",
      " * ESTIMATOR_TARE_MAX samples; offsets start at 0). */",
      "#ifndef ESTIMATOR_TARE_MAX",
      f"#define ESTIMATOR_TARE_MAX {size}",
      "#endif",
      "void estimate_tare_reset(void);",
      f"void estimate_tare_add({kind}[ESTIMATOR_INPUTS]);",
      "void estimate_tare_end(void);", ""]
  name = "counts" if counts else "inputs"
  source = [
      f"static float tare_offset[{c}];",
      f"static float tare_kept[ESTIMATOR_TARE_MAX][{c}];",
      "static int tare_n;",
      "",
      "void estimate_tare_reset(void) { tare_n = 0; }",
      "",
      f"void estimate_tare_add({kind}[ESTIMATOR_INPUTS]) {{",
      "  if (tare_n >= ESTIMATOR_TARE_MAX) return;",
      f"  for (int i = 0; i < {c}; ++i) tare_kept[tare_n][i] = (float){name}[i];",
      "  ++tare_n;",
      "}",
      "",
      "void estimate_tare_end(void) {  /* the median of each channel, by insertion sort */",
      "  static float v[ESTIMATOR_TARE_MAX];",
      "  if (tare_n == 0) return;",
      f"  for (int i = 0; i < {c}; ++i) {{",
      "    for (int k = 0; k < tare_n; ++k) {",
      "      float e = tare_kept[k][i];",
      "      int j = k;",
      "      for (; j > 0 && v[j - 1] > e; --j) v[j] = v[j - 1];",
      "      v[j] = e;",
      "    }",
      "    tare_offset[i] = (tare_n % 2) ? v[tare_n / 2]",
      "                                 : 0.5f * (v[tare_n / 2 - 1] + v[tare_n / 2]);",
      "  }",
      "}"]
  return header, source


def write(est, out_dir, budget: Budget = Budget(), fixed_point: bool = False) -> Report:
  """Writes out_dir/estimator.h and out_dir/estimator.c for `est`; returns their cost.

  fixed_point: a recurrent network's gates and state in Q16 integers (`_Writer.gru_fixed`),
  the rest in float: its outputs then differ from `predict` by the rounding of Q16 and the
  tanh table (measured on the footpad: `temporal_calibrators`), not by float32's.
  """
  from calibrate import estimators
  c = est.n_inputs
  a = _outputs(est)
  w = _Writer(fixed_point)
  mem = est.memory
  front = w.memory(mem, "raw") if mem is not None else []
  width = mem.width if mem is not None else c  # what the stages read
  members = est.members or (est,)
  if est.parts:  # AUTO: each kept candidate into its own array, then each output from one
    body = [f"  float part[{len(est.parts)}][{a}];"]
    ls = est.guard()
    if ls is not None:  # beyond the training box: as `Estimator._guarded`
      lo, hi = w.array("BOX_LO", est.info.input_lo), w.array("BOX_HI", est.info.input_hi)
      body += [f"  float inside[{c}], plane[{a}];",
               f"  for (int i = 0; i < {c}; ++i) inside[i] = x[i] < {lo}[i] ? {lo}[i] : "
               f"(x[i] > {hi}[i] ? {hi}[i] : x[i]);"]
      # the LS part at the box's nearest point (x shadowed by it in the block)
      body += ["  {", "    const float *x = inside;"] + [
          "  " + line for line in _compute(est.parts[ls], w, c, a, "plane", "BOX_")] + ["  }"]
    for k, part in enumerate(est.parts):
      if ls is not None and part.kind in (estimators.Kind.LSANN, estimators.Kind.NN):
        body += ["  {", "    const float *x = inside;"] + [
            "  " + line for line in _compute(part, w, c, a, f"part[{k}]", f"P{k}_")] + ["  }"]
      else:
        body += _compute(part, w, c, a, f"part[{k}]", f"P{k}_")
    for j, k in enumerate(est.pick):
      guarded = ls is not None and est.parts[k].kind in (estimators.Kind.LSANN,
                                                          estimators.Kind.NN)
      body.append(f"  out[{j}] = part[{k}][{j}]" + (f" + part[{ls}][{j}] - plane[{j}];"
                                                    if guarded else ";"))
  else:
    body = _compute(est, w, width, a, "out")
  names = est.info.outputs if est.info is not None else tuple(f"out{j}" for j in range(a))
  units = est.info.output_units if est.info is not None else ("",) * a
  inputs = est.info.inputs if est.info is not None else tuple(f"in{i}" for i in range(c))
  counts = integer_inputs(est)
  arg = "const uint16_t counts[ESTIMATOR_INPUTS]" if counts else \
      "const float inputs[ESTIMATOR_INPUTS]"
  in_units = est.info.input_units if est.info is not None else ("counts",) * c
  tare = _tare(est)
  tare_h, tare_c = _tare_code(tare, c, counts, est.info) if tare else ([], [])
  header = "\n".join([
      "/* Force estimator exported by the tactile testbench (python -m calibrate export).",
      f" * Method {est.kind.value}" + (f", mean of {len(members)} members" if est.members
                                       else "")
      + (": " + ", ".join(f"{comment_text(n)} from {est.parts[k].kind.value}"
                          for n, k in zip(est.info.outputs, est.pick)) if est.parts else "")
      + "; float32 weights; C99, <math.h> only.",
      " * Inputs: " + ", ".join(f"{comment_text(n)} ({comment_text(u)})"
                                for n, u in zip(inputs, in_units))
      + ("." if counts else "; as float: they were not integer counts when fitted.")
      + ("\n * fit undid the registers' wrap-around (--unwrap): unwrap them before estimate()."
         if est.info is not None and (est.info.settings.get("prepare") or {}).get(
             "unwrap_periods") else ""),
      " * Outputs: " + ", ".join(f"{comment_text(n)} ({comment_text(u)})"
                                 for n, u in zip(names, units)) + ". */",
      "#ifndef TESTBENCH_ESTIMATOR_H", "#define TESTBENCH_ESTIMATOR_H", "",
      "#include <stdint.h>", "",
      f"#define ESTIMATOR_INPUTS {c}", f"#define ESTIMATOR_OUTPUTS {a}", "",
      f"/* where each column sits in {'counts' if counts else 'inputs'}[] and out[] */"]
      + [f"#define ESTIMATOR_IN_{n} {i}" for i, n in enumerate(identifiers(inputs))]
      + [f"#define ESTIMATOR_OUT_{n} {j}" for j, n in enumerate(identifiers(names))] + ["",
      f"void estimate({arg}, float out[ESTIMATOR_OUTPUTS]);", ""]
      + (["/* A temporal estimator: estimate() reads the recording's past (drift tracking,",
          " * filters, a recurrent network's state), so call it on every sample, in order,",
          f" * every {mem.dt:g} s. estimate_reset(): a new session (power-up; the tare's",
          " * offset back to zero). estimate_restart(): a new episode of the same session",
          " * (the filters and the recurrent state start afresh; the tare's offset carries",
          " * on, as the drift does). */",
          f"#define ESTIMATOR_SAMPLE_SECONDS {_literal(mem.dt)}",
          "void estimate_reset(void);", "void estimate_restart(void);", ""]
         if mem is not None else [])
      + tare_h + ["#endif", ""])
  name = "counts" if counts else "inputs"
  first = (" - tare_offset[i];" if tare else ";")
  if mem is None:
    inputs_code = [f"  float x[{c}];",
                   f"  for (int i = 0; i < {c}; ++i) x[i] = (float){name}[i]" + first]
  else:
    inputs_code = [f"  float raw[{c}], x[{width}];",
                   f"  for (int i = 0; i < {c}; ++i) raw[i] = (float){name}[i]" + first
                   ] + front
  reset = ["", "void estimate_restart(void) {"] + w.resets + ["}", "",
           "void estimate_reset(void) {"] + w.session_resets + ["  estimate_restart();", "}"] \
      if mem is not None else []
  source = "\n".join(
      ['#include "estimator.h"', "#include <math.h>", ""] + w.arrays + w.state + tare_c
      + reset + ["",
                 f"void estimate({arg}, float out[ESTIMATOR_OUTPUTS]) {{"]
      + inputs_code + body + ["}", ""])
  out_dir = pathlib.Path(out_dir)
  out_dir.mkdir(parents=True, exist_ok=True)
  files.write_text(out_dir / "estimator.h", header)
  files.write_text(out_dir / "estimator.c", source)
  stack = w.stack + 4 * (c + width * (mem is not None) + 2 * a + a * len(est.parts))
  macs = w.macs
  cycles = tuple(macs * mc + w.tanh * tc + w.fixed_macs * fm + w.fixed_tanh * ft
                 for mc, tc, fm, ft in zip(budget.mac_cycles, budget.tanh_cycles,
                                           budget.fixed_mac_cycles, budget.fixed_tanh_cycles))
  return Report(macs, w.tanh, w.flash, stack, cycles, budget,
                (str(out_dir / "estimator.h"), str(out_dir / "estimator.c")),
                w.fixed_macs, w.fixed_tanh)


HOST_HARNESS = r"""
#include <stdio.h>
#include "estimator.h"
int main(void) {  /* lines "session segment inputs...": a new session resets, a new
                     segment restarts */
  long session, label, last_session = -1, last = -1;
  while (scanf("%ld %ld", &session, &label) == 2) {
    float out[ESTIMATOR_OUTPUTS];
    double v;
    ESTIMATOR_INPUT_TYPE in[ESTIMATOR_INPUTS];
    for (int i = 0; i < ESTIMATOR_INPUTS; ++i) {
      if (scanf("%lf", &v) != 1) return 1;
      in[i] = (ESTIMATOR_INPUT_TYPE)v;
    }
    RESET_IF_NEW
    last = label;
    last_session = session;
    estimate(in, out);
    for (int j = 0; j < ESTIMATOR_OUTPUTS; ++j) printf("%.9g ", out[j]);
    printf("\n");
  }
  (void)last;
  (void)last_session;
  return 0;
}
"""


def run_on_host(est, counts: np.ndarray, segments: Optional[np.ndarray] = None,
                fixed_point: bool = False, cc: Optional[str] = None,
                sessions: Optional[np.ndarray] = None) -> np.ndarray:
  """(N, A) what the exported C computes over `counts` (N, C) in time order, compiled for
  this machine (`cc`, default $CC, cc, gcc or clang; C99 with every warning an error),
  restarted at each new `segments` label and reset at each new `sessions` label (None: at
  each segment), as `predict` reads them: the export checked against `predict` on a
  recording.

  Raises:
    errors.SettingError when no C compiler is found.
  """
  import os
  import shutil
  import subprocess
  import tempfile
  cc = cc or os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc") or \
      shutil.which("clang")
  if cc is None:
    raise errors.SettingError("no C compiler found to run the export on (set CC, or install "
                              "gcc)")
  counts = np.asarray(counts, float)
  labels = np.zeros(len(counts), int) if segments is None else np.asarray(segments)
  with tempfile.TemporaryDirectory() as d:
    d = pathlib.Path(d)
    write(est, d, fixed_point=fixed_point)
    integer = integer_inputs(est)
    harness = HOST_HARNESS.replace("ESTIMATOR_INPUT_TYPE", "uint16_t" if integer else "float")
    harness = harness.replace(
        "RESET_IF_NEW", "if (session != last_session) estimate_reset(); else if (label != "
        "last) estimate_restart();" if est.memory is not None else "")
    (d / "main.c").write_text(harness)
    built = subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic",
                            str(d / "estimator.c"), str(d / "main.c"), "-lm", "-o",
                            str(d / "est")], capture_output=True, text=True)
    if built.returncode:  # the export's own bug: the compiler says where
      raise RuntimeError(f"the exported C did not compile with {cc}:\n{built.stderr[-3000:]}")
    def codes(lab):  # +1 at each change of label
      return np.concatenate([[0], np.cumsum(lab[1:] != lab[:-1])])
    sess = codes(labels if sessions is None else np.asarray(sessions))
    text = "\n".join(f"{a} {k} " + " ".join(repr(float(v)) for v in row)
                     for a, k, row in zip(sess, codes(labels), counts))
    run = subprocess.run([str(d / "est")], input=text, capture_output=True, text=True,
                         check=True)
  return np.array([[float(v) for v in line.split()] for line in run.stdout.splitlines()])


def arm_instructions_per_estimate(out_dir, bench_source: str, calls: int = 20) -> float:
  """Instructions the exported estimator in `out_dir` executes per `estimate()`, as this
  module's cost model was measured: `bench_source` (a main() that calls estimate() argv[1]
  times) compiled with it by Debian's arm-linux-gnueabi-gcc for Thumb-2 soft float, and run
  in qemu-arm single-stepping, `calls` calls against none.

  Raises:
    errors.SettingError when arm-linux-gnueabi-gcc or qemu-arm is missing.
  """
  import shutil
  import subprocess
  cc, qemu = shutil.which("arm-linux-gnueabi-gcc"), shutil.which("qemu-arm")
  if cc is None or qemu is None:
    raise errors.SettingError("counting instructions needs Debian's gcc-arm-linux-gnueabi and "
                              "qemu-user")
  out_dir = pathlib.Path(out_dir)
  (out_dir / "bench.c").write_text(bench_source)
  exe = out_dir / "bench"
  subprocess.run([cc, "-std=c99", "-O2", "-mcpu=cortex-a8", "-mthumb", "-mfloat-abi=soft",
                  "-static", str(out_dir / "estimator.c"), str(out_dir / "bench.c"), "-lm",
                  "-o", str(exe)], check=True, capture_output=True)

  def executed(n):
    log = out_dir / f"q{n}.log"
    subprocess.run([qemu, "-singlestep", "-d", "exec,nochain", "-D", str(log), str(exe),
                    str(n)], check=True, capture_output=True)
    with open(log) as f:
      return sum(1 for line in f if line.startswith("Trace"))
  return (executed(calls) - executed(0)) / calls
