"""The LSANN paper's numbers (Chuah & Kim, the MIT Cheetah footpad), each once: what the
footpad's benchmarks compare with."""

from __future__ import annotations

# Table I, test paths: RMSE N, NRMSE %, R2 %
TABLE1 = {
    "LSANN": {"Z": (2.58, 1.17, 99.78), "Y": (12.84, 10.14, 72.22), "X": (10.48, 8.30, 81.03)},
    "NN": {"Z": (2.42, 1.10, 99.90), "Y": (12.63, 9.98, 79.02), "X": (11.17, 8.85, 83.62)},
}
LS_TRAIN_NRMSE = {"Z": 0.42, "Y": 5.72, "X": 9.63}  # Sec. III-B: the linear fit, its strokes
LS_TRAIN_RANGE = {"Z": 221.05, "Y": 233.35, "X": 218.99}  # N, Sec. III-B: the ranges of that data
MINUTES = {"LSANN": 59.0, "NN": 144.5}  # training time
TIME_RATIO = MINUTES["LSANN"] / MINUTES["NN"]  # LSANN over NN-only: 0.41 (-59.2 %)
