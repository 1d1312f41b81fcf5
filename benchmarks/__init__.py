"""Named benchmarks of the testbench: `python -m benchmarks.run NAME`."""

from util import blas

blas.pin()  # before NumPy loads OpenBLAS: the same bytes on every x86-64 machine
