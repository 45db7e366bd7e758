"""The numbers of docs/drilling.md, regenerated: ``python -m drill_string.study [--figures DIR]``.

Prints markdown: derived parameters against Paper IV Tables 2-3, the decoupled axial
stability against section 4.2, critical speeds against n (Figs. 3-4 like), the viscosity map
of Fig. 7, the OP1/OP2 runs of Fig. 9 and the Fig. 5-6 runs, simulation speed, and the
step-size convergence study. Takes about a minute on one core.
"""
from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from .convergence import convergence_study, format_table
from .parameters import derive
from .simulate import (DrillingConfig, longest_stick_s, paper_fig9_config,
                       rate_of_penetration_m_s, simulate, stick_slip_severity,
                       stick_time_fraction)
from .stability import axial_stability
from .stability_report import (critical_speed_table, critical_speeds, crossing_table,
                               stability_map, stability_map_figure)

NS = (1, 2, 3, 5, 10, 20, 30, 40)


def fig56_config(section: str) -> DrillingConfig:
    """Paper IV section 5.2: n = 2, uniform pipe, V0 = 0.05 m/s, 150 rpm, all blocks
    starting at half the top-drive speed."""
    return DrillingConfig(section=section, n_elements=2, with_bha=False, top_drive_rpm=150.0,
                          block_speed_m_s=0.05, initial_rotation_fraction=0.5)


def parameter_rows() -> str:
    lines = ["| case | t* (s) | d_hat | c_hat | n_b alpha | lambda (m) | beta | n^2 c_bar^2 | "
             "a_hat r_b alpha / (2 l_hat zeta) |", "| --- " * 9 + "|"]
    for key in (("36in", 2, False), ("12.25in", 2, False), ("12.25in", 6, True)):
        p = derive(*key)
        r = p.table_row()
        lines.append(f"| {key[0]} n={key[1]}{' BHA' if key[2] else ''} | {p.t_star_s:.4f} | "
                     f"{r['d_hat']:.4g} | {r['c_hat']:.4g} | {r['nb_alpha']:.1f} | "
                     f"{r['lambda']:.4g} | {r['beta']:.4f} | {r['n2_cbar2']:.2f} | "
                     f"{r['torque_gain']:.0f} |")
    return "\n".join(lines)


def run_metrics(name: str, cfg: DrillingConfig, tau_end: float, tau_from: float,
                repeats: int = 3) -> str:
    t_star = cfg.parameters().t_star_s
    walls, cpus = [], []
    for _ in range(repeats):
        start, cpu = time.perf_counter(), time.process_time()
        tr = simulate(cfg, tau_end * t_star)
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - cpu)
    wall, cpu = statistics.median(walls), statistics.median(cpus)
    s0 = tau_from * t_star
    return (f"| {name} | {tr.time_s[-1]:.1f} | {stick_slip_severity(tr, s0):.2f} | "
            f"{stick_time_fraction(tr, s0):.3f} | {longest_stick_s(tr, s0) / t_star:.2f} | "
            f"{rate_of_penetration_m_s(tr, s0) * 3600:.1f} | {np.max(tr.wob_n) / 1e3:.0f} | "
            f"{tr.meta['step_s'] * 1e3:.3g} | {wall:.2f} | {tr.time_s[-1] / wall:.0f} | "
            f"{tr.time_s[-1] / cpu:.0f} |")


def metric_convergence(cfg: DrillingConfig, steps=(0.01, 0.005, 0.0025, 0.001)) -> str:
    t_star = cfg.parameters().t_star_s
    lines = ["| scheme | step (scaled) | severity | stick fraction | longest stick (t*) | "
             "ROP (m/h) |", "| --- " * 6 + "|"]
    for scheme in ("newmark", "generalized_alpha", "rk4"):
        for h in steps:
            tr = simulate(replace(cfg, scheme=scheme), 100 * t_star, h * t_star)
            s0 = 65 * t_star
            lines.append(f"| {scheme} | {h:g} | {stick_slip_severity(tr, s0):.2f} | "
                         f"{stick_time_fraction(tr, s0):.3f} | "
                         f"{longest_stick_s(tr, s0) / t_star:.2f} | "
                         f"{rate_of_penetration_m_s(tr, s0) * 3600:.1f} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figures", type=Path, help="write the figures (PNG) into this folder")
    ap.add_argument("--skip-convergence", action="store_true")
    args = ap.parse_args(argv)

    print("## Derived parameters (Tables 2-3)\n")
    print(parameter_rows())
    r = axial_stability("36in", 2)
    print("\n## 36in, n = 2 (section 4.2)\n")
    print(f"d_hat = {r.d_hat:.4e}; omega_j = {np.round(r.eigenfrequencies, 4).tolist()}; "
          f"omega_k* = {np.round(r.crossing_frequencies, 4).tolist()}; "
          f"sign F' = {r.directions.tolist()}; delay margin {r.delay_margin:.4f} t*; "
          f"critical speed {r.critical_speed_rpm:.1f} rpm\n")
    print(crossing_table(r))
    bha = axial_stability("12.25in", 6, True)
    print(f"\n12.25in n = 6 BHA mu = 0.03: omega_j = {np.round(bha.eigenfrequencies, 4).tolist()}"
          f"; stable bands (rpm) = {[(round(a, 1), round(b, 1)) for a, b in bha.stable_speed_bands_rpm()]}"
          f"; OP1 stable: {bha.is_stable_at(120)}; OP2 stable: {bha.is_stable_at(160)}")
    uniform = critical_speeds(ns=NS, with_bha=False)
    with_bha = critical_speeds(ns=NS, with_bha=True)
    print("\n## Critical speed (rpm) vs n, uniform pipe (Fig. 3 like)\n")
    print(critical_speed_table(uniform, NS))
    print("\n## Critical speed (rpm) vs n, with BHA (Fig. 4 like)\n")
    print(critical_speed_table(with_bha, NS))
    bands = stability_map("12.25in", 6, True, viscosities=(1e-4, 1e-3, 0.01, 0.03, 0.1, 0.3, 1.0))
    print("\n## 12.25in n = 6 BHA: stable bands (rpm) vs viscosity (Fig. 7 like)\n")
    for mu, spans in bands:
        print(f"- mu = {mu:g} Pa s: " + ", ".join(f"{a:.1f}-{b:.1f}" for a, b in spans))

    print("\n## Runs (Newmark, default step)\n")
    print("| run | simulated s | severity | stick fraction | longest stick (t*) | ROP (m/h) | "
          "max WOB (kN) | step (ms) | wall s | simulated s per wall s | "
          "simulated s per CPU s |")
    print("| --- " * 11 + "|")
    print(run_metrics("OP1 12.25in n=6 BHA 120 rpm, tau 65-100", paper_fig9_config(120.0),
                      100.0, 65.0))
    print(run_metrics("OP2 12.25in n=6 BHA 160 rpm, tau 65-100", paper_fig9_config(160.0),
                      100.0, 65.0))
    print(run_metrics("Fig. 5: 36in n=2 150 rpm, tau 0-100", fig56_config("36in"), 100.0, 0.0))
    print(run_metrics("Fig. 6: 12.25in n=2 150 rpm, tau 0-100", fig56_config("12.25in"),
                      100.0, 0.0))

    if not args.skip_convergence:
        cfg = paper_fig9_config(160.0)
        rows, ref_cost = convergence_study(cfg, 20 * cfg.parameters().t_star_s)
        print("\n## Convergence, OP2 over 20 t* (no stick), reference RK4 at 2.5e-4 t*\n")
        print(format_table(rows))
        print(f"\n(reference: {ref_cost:.3f} wall s per simulated s)")
        print("\n## Stick-slip metrics vs step, OP1, tau 65-100\n")
        print(metric_convergence(paper_fig9_config(120.0)))

    if args.figures:
        args.figures.mkdir(parents=True, exist_ok=True)
        _figures(args.figures, uniform, with_bha, stability_map("12.25in", 6, True))


def _figures(folder: Path, uniform, with_bha, bands) -> None:
    from matplotlib.figure import Figure
    fig = Figure(figsize=(12, 8))
    axes = fig.subplots(2, 2)
    for ax, speeds, title in ((axes[0, 0], uniform, "uniform pipe (Fig. 3 like)"),
                              (axes[0, 1], with_bha, "with BHA (Fig. 4 like)")):
        for name, values in speeds.items():
            ax.semilogy(NS, values, marker="o", ms=3, label=name)
        ax.set_title(f"critical top-drive speed, {title}")
        ax.set_xlabel("n")
        ax.set_ylabel("rpm")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for ax, rpm, label in ((axes[1, 0], 120.0, "OP1 120 rpm"), (axes[1, 1], 160.0, "OP2 160 rpm")):
        cfg = paper_fig9_config(rpm)
        t_star = cfg.parameters().t_star_s
        tr = simulate(cfg, 100 * t_star)
        tau = tr.time_s / t_star
        ax.plot(tau, tr.bit_speed_rad_s, lw=0.6, label="bit speed (rad/s)")
        ax.plot(tau, tr.bit_axial_speed_m_s * 100, lw=0.4, label="bit axial speed (cm/s)")
        ax.set_title(f"12.25in n = 6 with BHA, {label} (Fig. 9 like)")
        ax.set_xlabel("t / t*")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(folder / "drilling-study.png", dpi=80)
    stability_map_figure(bands, points=((0.03, 120.0, "OP1"), (0.03, 160.0, "OP2")),
                         title="12.25in n = 6 with BHA: stable regions (Fig. 7 like)") \
        .savefig(folder / "drilling-map.png", dpi=80)


if __name__ == "__main__":
    main()
