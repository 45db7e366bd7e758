"""Tables and figures of the decoupled axial stability (like Tengesdal (2021), Paper IV
Figs. 3, 4 and 7). Figures are ``matplotlib.figure.Figure`` objects (no pyplot, no backend
state); the caller saves or shows them. The analysis itself is in ``stability``."""
from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from .parameters import SECTIONS
from .stability import StabilityResult, axial_stability

DEFAULT_NS = (1, 2, 3, 4, 5, 6, 8, 10, 15, 20, 25, 30, 35, 40)


def critical_speeds(sections=tuple(SECTIONS), ns=DEFAULT_NS,
                    with_bha: bool = False) -> dict[str, list[float]]:
    """Critical top-drive speed (rpm) per section and n: above it the decoupled axial
    motion is stable."""
    return {s: [axial_stability(s, n, with_bha).critical_speed_rpm for n in ns]
            for s in sections}


def critical_speed_table(speeds: dict[str, list[float]], ns=DEFAULT_NS) -> str:
    head = "| n | " + " | ".join(speeds) + " |"
    rule = "| --- " * (len(speeds) + 1) + "|"
    rows = [f"| {n} | " + " | ".join(f"{speeds[s][i]:.1f}" for s in speeds) + " |"
            for i, n in enumerate(ns)]
    return "\n".join([head, rule, *rows])


def critical_speed_figure(speeds: dict[str, list[float]], ns=DEFAULT_NS,
                          title: str = "") -> Figure:
    """Critical rpm against n on a log scale (Figs. 3 and 4 of Paper IV)."""
    fig = Figure(figsize=(7, 4.5))
    ax = fig.add_subplot()
    for name, values in speeds.items():
        ax.semilogy(ns, values, marker="o", ms=3, label=name)
    ax.set_xlabel("number of blocks n")
    ax.set_ylabel("critical top-drive speed (rpm)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig


def crossing_table(result: StabilityResult, first_delays: int = 3) -> str:
    """Crossing frequencies, directions, phases and the first critical delays (40)."""
    lines = ["| omega_k* | sign F' | theta_k (rad) | first delays tau_n,k,r |",
             "| --- | --- | --- | --- |"]
    for k, w in enumerate(result.crossing_frequencies):
        delays = ", ".join(f"{d:.4f}" for d in result.critical_delays(k)[:first_delays])
        lines.append(f"| {w:.4f} | {'+' if result.directions[k] > 0 else '-'} | "
                     f"{result.phases[k]:.4f} | {delays} |")
    return "\n".join(lines)


def stability_map(section: str, n: int, with_bha: bool = True,
                  viscosities=tuple(np.geomspace(1e-4, 1.0, 25))) -> list[tuple[float, list]]:
    """Stable speed bands (rpm) against mud viscosity (Fig. 7 of Paper IV)."""
    return [(float(mu), axial_stability(section, n, with_bha,
                                        mud_viscosity_pa_s=float(mu)).stable_speed_bands_rpm())
            for mu in viscosities]


def stability_map_figure(bands, max_rpm: float = 400.0, points=(), title: str = "") -> Figure:
    """Stable regions (shaded) in the (viscosity, rpm) plane; ``points`` are (mu, rpm, label)
    operating points to mark."""
    fig = Figure(figsize=(7, 4.5))
    ax = fig.add_subplot()
    mus = np.array([b[0] for b in bands])
    logs = np.log10(mus)
    mids = 0.5 * (logs[1:] + logs[:-1])
    step = (logs[-1] - logs[0]) / max(1, logs.size - 1) or 0.1
    edges = 10 ** np.concatenate([[logs[0] - step / 2], mids, [logs[-1] + step / 2]])
    for (mu, spans), left, right in zip(bands, edges[:-1], edges[1:]):
        for lo, hi in spans:
            hi = min(hi, max_rpm) if math.isfinite(hi) else max_rpm
            ax.fill_between([left, right], lo, hi, color="tab:blue", alpha=0.35, lw=0)
    for mu, rpm, label in points:
        ax.plot(mu, rpm, "k^")
        ax.annotate(label, (mu, rpm), textcoords="offset points", xytext=(4, 4))
    ax.set_xscale("log")
    ax.set_ylim(0, max_rpm)
    ax.set_xlabel("mud viscosity (Pa s)")
    ax.set_ylabel("top-drive speed (rpm)")
    ax.set_title(title or "decoupled axial stability: stable regions shaded")
    fig.tight_layout()
    return fig
