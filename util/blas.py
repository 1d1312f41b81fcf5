"""One BLAS code path on every x86-64 machine, for the same bytes from the same seed.

NumPy's and SciPy's OpenBLAS pick their kernels by the CPU at load time. An AVX-512 machine
(SkylakeX kernels) sums in another order than an AVX2 one (Haswell), so the footpad's
finite-element kernel differs in its last bits, z_press's depth with it, and so every noise
stream keyed by the CNC commands (measured on 2026-11-28: on an AVX-512 AMD EPYC, the
shipped example's train.csv came out 7-18 counts RMS apart with the auto-detected SkylakeX
kernels, and byte for byte with OPENBLAS_CORETYPE=Haswell). `pin()` asks for the Haswell
kernels, which every x86-64 CPU with AVX2 runs, unless the user chose a core type; it acts
only before NumPy is first imported in the process (OpenBLAS reads it when it loads)."""

from __future__ import annotations

import functools
import os
import platform


def pin() -> None:
  if platform.machine().lower() in ("x86_64", "amd64"):
    os.environ.setdefault("OPENBLAS_CORETYPE", "Haswell")


@functools.lru_cache(maxsize=1)  # the BLAS a process loaded stays: asked once
def architecture() -> str:
  """The BLAS kernels NumPy runs on, as OpenBLAS names them ("Haswell", "SkylakeX"; the
  library's name where it reports none): a cached result computed by them carries it in its
  key, since another choice gives other last bits (measured on 2026-11-29: the footpad's die
  kernel cached from SkylakeX before `pin` differed from Haswell's by 2e-14 of its largest
  value, and the paper-scale Table I simulated with it drew other noise streams: NN-only X
  R2 76.80 % against 87.08 %)."""
  import numpy  # noqa: F401  (loads the BLAS threadpoolctl reads)
  import threadpoolctl
  found = sorted({f"{i.get('internal_api')}:{i.get('architecture') or ''}"
                  for i in threadpoolctl.threadpool_info() if i.get("user_api") == "blas"})
  return ",".join(found) or os.environ.get("OPENBLAS_CORETYPE", "")
