"""Calibrators: arrays in, estimators out (`python -m calibrate`)."""

from util import blas

blas.pin()  # before NumPy loads OpenBLAS: the same bytes on every x86-64 machine
