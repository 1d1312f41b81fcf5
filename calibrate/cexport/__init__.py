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

import numpy as np

from calibrate.cexport import skeleton
from calibrate.cexport.emitter import Emitter
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


def write(est, out_dir, budget: Budget = Budget(), fixed_point: bool = False) -> Report:
  """Writes out_dir/estimator.h and out_dir/estimator.c for `est`; returns their cost.

  fixed_point: a recurrent network's gates and state in Q16 integers
  (`calibrate.parts.gru.GRU`), the rest in float: its outputs then differ from `predict` by
  the rounding of Q16 and the tanh table (measured on the footpad: `temporal_calibrators`),
  not by float32's.
  """
  from calibrate import compose
  c, a = est.n_inputs, est.root.n_outputs
  em = Emitter(fixed_point)
  mem = est.memory
  front = mem.emit_front(em, "raw") if mem is not None else []
  stage = est.root.stage if mem is not None else est.root
  width = mem.width if mem is not None else c  # what the stages read
  if isinstance(stage, compose.PerOutput):  # each output from one part
    body = stage.emit_c(em, "", c)
  else:
    body = compose.emit_estimate(stage, em, est.kind.value, width, a, "out")
  counts = skeleton.integer_inputs(est)
  tare = skeleton.tare_rule(est)
  header = skeleton.header(est, c, a, counts, tare)
  source = skeleton.source(em, est, c, width, counts, tare, front, body)
  out_dir = pathlib.Path(out_dir)
  out_dir.mkdir(parents=True, exist_ok=True)
  files.write_text(out_dir / "estimator.h", header)
  files.write_text(out_dir / "estimator.c", source)
  parts = len(stage.parts) if isinstance(stage, compose.PerOutput) else 0
  stack = em.stack + 4 * (c + width * (mem is not None) + 2 * a + a * parts)
  cycles = tuple(em.macs * mc + em.tanh * tc + em.fixed_macs * fm + em.fixed_tanh * ft
                 for mc, tc, fm, ft in zip(budget.mac_cycles, budget.tanh_cycles,
                                           budget.fixed_mac_cycles, budget.fixed_tanh_cycles))
  return Report(em.macs, em.tanh, em.flash, stack, cycles, budget,
                (str(out_dir / "estimator.h"), str(out_dir / "estimator.c")),
                em.fixed_macs, em.fixed_tanh)


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
    integer = skeleton.integer_inputs(est)
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
