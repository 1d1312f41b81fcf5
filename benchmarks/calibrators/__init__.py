"""Benchmarks of the calibrators across both rigs: what accuracy costs in training time."""
