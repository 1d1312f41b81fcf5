"""The simulated rigs (the footpad, the shell) on their shared core."""

from util import blas

blas.pin()  # before NumPy loads OpenBLAS: the same bytes on every x86-64 machine
