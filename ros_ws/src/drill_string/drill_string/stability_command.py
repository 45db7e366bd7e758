"""``rig stability SECTION --elements N [--bha] [--output DIR]``: the decoupled axial
stability of one string (Tengesdal (2021), Paper IV section 3.1) printed as a table, and
with ``--output`` the figures like Paper IV Figs. 3, 4 and 7 written as PNG files."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .parameters import SECTIONS
from .stability import StabilityResult, axial_stability
from .stability_report import (critical_speed_figure, critical_speeds, crossing_table,
                               stability_map, stability_map_figure)

FIGURE_DPI = 90


def _bands_text(result: StabilityResult) -> str:
    out = []
    for low, high in result.stable_speed_bands_rpm():
        out.append(f"> {low:.1f}" if math.isinf(high) else f"{low:.1f}-{high:.1f}")
    return ", ".join(out) or "none"


def stability_text(result: StabilityResult) -> str:
    """The analysis as printed: the string, its axial eigenfrequencies, the crossing
    frequencies with their direction, phase and first critical delays (Paper IV eqs.
    (37)-(40)), the delay margin and the critical top-drive speed. Delays and
    frequencies are in the paper's scaled time (t* = L / c_t)."""
    string = "with BHA" if result.with_bha else "uniform pipe"
    margin_s = result.delay_margin * result.t_star_s
    lines = [
        f"Decoupled axial stability: {result.section}, n = {result.n}, {string}, "
        f"mud viscosity {result.mud_viscosity_pa_s:g} Pa s",
        f"  t* = {result.t_star_s:.4f} s, d_hat = {result.d_hat:.4e}, "
        f"n_b alpha = {result.nb_alpha:.1f}",
        "  axial eigenfrequencies omega_j (1/t*): "
        + ", ".join(f"{w:.4f}" for w in result.eigenfrequencies),
        "",
        crossing_table(result),
        "",
        f"  delay margin          {result.delay_margin:.4f} t* ({margin_s * 1e3:.2f} ms)",
        f"  critical speed        {result.critical_speed_rpm:.1f} rpm "
        f"({result.critical_speed_rad_s:.2f} rad/s): stable above, unstable just below",
        f"  stable speeds (rpm)   {_bands_text(result)}",
    ]
    return "\n".join(lines)


def write_figures(result: StabilityResult, output: Path, ns=None) -> list[Path]:
    """Figs. 3 and 4 like (critical speed against n for every Table 1 section, uniform and
    with BHA) and Fig. 7 like (stable speed bands against mud viscosity for this string,
    its Table 1 viscosity marked at the critical speed). ``ns`` the n of Figs. 3-4
    (default ``stability_report.DEFAULT_NS``)."""
    output.mkdir(parents=True, exist_ok=True)
    kw = {} if ns is None else {"ns": tuple(ns)}
    paths = []
    for with_bha, name, title in ((False, "fig3_critical_speed_uniform.png",
                                   "uniform pipe (Fig. 3 like)"),
                                  (True, "fig4_critical_speed_bha.png", "with BHA (Fig. 4 like)")):
        speeds = critical_speeds(tuple(SECTIONS), with_bha=with_bha, **kw)
        fig = critical_speed_figure(speeds, title=f"critical top-drive speed, {title}", **kw)
        paths.append(output / name)
        fig.savefig(paths[-1], dpi=FIGURE_DPI)
    bands = stability_map(result.section, result.n, result.with_bha,
                          viscosities=tuple(np.geomspace(1e-4, 1.0, 25)))
    top = max(400.0, 1.5 * result.critical_speed_rpm)
    string = "with BHA" if result.with_bha else "uniform"
    fig = stability_map_figure(
        bands, max_rpm=top,
        points=((result.mud_viscosity_pa_s, result.critical_speed_rpm, "critical"),),
        title=f"{result.section} n = {result.n} {string}: stable regions (Fig. 7 like)")
    paths.append(output / "fig7_stability_map.png")
    fig.savefig(paths[-1], dpi=FIGURE_DPI)
    return paths


def run(section: str, n: int, with_bha: bool, mud_viscosity_pa_s: float | None = None,
        output: Path | None = None) -> tuple[str, list[Path]]:
    """The printed table and the figures written (none without ``output``)."""
    result = axial_stability(section, n, with_bha, mud_viscosity_pa_s=mud_viscosity_pa_s)
    paths = write_figures(result, output) if output is not None else []
    return stability_text(result), paths
