"""The force-sensing shell paper's numbers (Goldberg & Fearing), each once: what the shell's
benchmarks and design objective compare with. SI units (N, N m) unless stated."""

from __future__ import annotations

AXES = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
# Table II, SkinProc row: range and resolution (standard deviation at rest) per axis
TABLE2 = {"Fx": (2.3, 0.0054), "Fy": (2.1, 0.0167), "Fz": (1.9, 0.0051),
          "Mx": (0.096, 0.00072), "My": (0.127, 0.00025), "Mz": (0.138, 0.00044)}
# Table I (test set, n = 42316): median % error, worst case % of range
TABLE1 = {"Fx": (18, 20), "Fy": (18, 59), "Fz": (16, 25), "Mx": (15, 43), "My": (7.6, 19),
          "Mz": (11, 28)}
