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

import os
import platform


def pin() -> None:
  if platform.machine().lower() in ("x86_64", "amd64"):
    os.environ.setdefault("OPENBLAS_CORETYPE", "Haswell")
