"""The papers' figures, drawn headless (matplotlib's Agg) into a run's `figures/` folder.

Each function takes plain arrays, returns the matplotlib Figure (so tests read its axes back)
and states units, benchmark and seed in its title. `save` writes a PNG atomically. The two any calibration draws (`over_time`, `scatter`) and
`save` live in `calibrate.figures`, which `python -m calibrate evaluate` uses too.

* `over_time`: predicted against measured force over time, one panel per axis (LSANN Fig. 7).
* `strokes`: counts and forces during the Z, X and Y strokes (LSANN Fig. 5).
* `scatter`: predicted against true, one panel per axis, with the 1:1 line (shell Fig. 7).
* `traces`: any named signals over time, one panel per group (shell Figs. 8 and 11).
* `heatmap`: a value over a 2-D grid of designs (the reflector slope sweep).
* `front`: error against training time per method, with the Pareto front (accuracy_vs_time).
"""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from calibrate.figures import MAX_POINTS, _pyplot, _thin, _title, over_time, save, scatter  # noqa: F401,E501

def strokes(segments: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
            channels: Sequence[str], axes: Sequence[str], *, benchmark: str, seed: int,
            count_unit: str = "counts", force_unit: str = "N"):
  """Per stroke (name: (time (N,) s, counts (N, C), forces (N, A))) a column: the counts
  above, the forces below."""
  plt = _pyplot()
  fig, panels = plt.subplots(2, len(segments), figsize=(4 * len(segments), 6), squeeze=False)
  for j, (name, (t, counts, forces)) in enumerate(segments.items()):
    keep = _thin(len(t))
    for c, label in enumerate(channels):
      panels[0, j].plot(t[keep], counts[keep, c], lw=0.8, label=label)
    for a, label in enumerate(axes):
      panels[1, j].plot(t[keep], forces[keep, a], lw=0.8, label=label)
    panels[0, j].set_title(name)
    panels[0, j].set_ylabel(f"sensor output ({count_unit})")
    panels[1, j].set_ylabel(f"force ({force_unit})")
    panels[1, j].set_xlabel("time (s)")
    for ax in panels[:, j]:
      ax.grid(alpha=0.3)
  panels[0, 0].legend(fontsize=7, ncol=2)
  panels[1, 0].legend(fontsize=7)
  _title(fig, "sensor output and force during the strokes", benchmark, seed)
  fig.tight_layout()
  return fig


def traces(time: np.ndarray, groups: dict[str, dict[str, np.ndarray]], units: dict[str, str],
           *, benchmark: str, seed: int, what: str,
           spans: Optional[Sequence[tuple[float, float, str]]] = None):
  """One panel per group (name: {label: (N,) signal}) against time (N,) s, its unit from
  `units`; `spans` shades (start s, end s, label) intervals on every panel."""
  plt = _pyplot()
  fig, panels = plt.subplots(len(groups), 1, figsize=(9, 2.3 * len(groups) + 0.8),
                             sharex=True, squeeze=False)
  keep = _thin(len(time))
  for ax, (name, signals) in zip(panels[:, 0], groups.items()):
    for label, y in signals.items():
      ax.plot(time[keep], np.asarray(y)[keep], lw=0.9, label=label)
    for k, (a, b, label) in enumerate(spans or ()):
      ax.axvspan(a, b, color="0.9" if k % 2 else "0.82", zorder=0)
      if ax is panels[0, 0]:
        ax.text((a + b) / 2, 1.0, label, transform=ax.get_xaxis_transform(), ha="center",
                va="bottom", fontsize=7)
    ax.set_ylabel(f"{name} ({units[name]})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
  panels[-1, 0].set_xlabel("time (s)")
  _title(fig, what, benchmark, seed)
  fig.tight_layout()
  return fig


def heatmap(x: np.ndarray, y: np.ndarray, value: np.ndarray, *, xlabel: str, ylabel: str,
            label: str, benchmark: str, seed: int, what: str,
            mark: Optional[tuple[float, float, str]] = None):
  """value (len(y), len(x)) over the grid x by y; `mark` puts a labelled cross at (x, y)."""
  plt = _pyplot()
  fig, ax = plt.subplots(figsize=(6, 5))
  image = ax.pcolormesh(x, y, value, shading="nearest", cmap="viridis")
  fig.colorbar(image, ax=ax, label=label)
  if mark is not None:
    ax.plot(mark[0], mark[1], "rx", ms=10, mew=2)
    ax.annotate(mark[2], mark[:2], textcoords="offset points", xytext=(6, 6), color="r",
                fontsize=8)
  ax.set_xlabel(xlabel)
  ax.set_ylabel(ylabel)
  _title(fig, what, benchmark, seed)
  fig.tight_layout()
  return fig


def pareto(seconds: np.ndarray, error: np.ndarray) -> np.ndarray:
  """Indices of the points no other point beats in both seconds and error, by seconds."""
  order = np.lexsort((error, seconds))
  best, keep = np.inf, []
  for i in order:
    if error[i] < best:
      keep.append(i)
      best = error[i]
  return np.array(keep, int)


def front(points: dict[str, tuple[np.ndarray, np.ndarray]], *, error_label: str,
          benchmark: str, seed: int, what: str):
  """Error against training seconds (log scale) per method (name: (seconds, error)), with the
  Pareto front over all of them."""
  plt = _pyplot()
  fig, ax = plt.subplots(figsize=(7, 5))
  for method, (s, e) in points.items():
    ax.plot(s, e, "o", ms=4, alpha=0.8, label=method)
  s = np.concatenate([np.asarray(p[0], float) for p in points.values()])
  e = np.concatenate([np.asarray(p[1], float) for p in points.values()])
  idx = pareto(s, e)
  ax.step(s[idx], e[idx], "k-", where="post", lw=1, label="Pareto front")
  ax.set_xscale("log")
  ax.set_xlabel("training time (s, after JIT)")
  ax.set_ylabel(error_label)
  ax.grid(alpha=0.3, which="both")
  ax.legend(fontsize=8)
  _title(fig, what, benchmark, seed)
  fig.tight_layout()
  return fig
