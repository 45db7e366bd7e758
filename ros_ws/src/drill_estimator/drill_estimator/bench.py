"""Timing of the UKF: one time update over a sensor frame and one measurement update.

``run_benchmark()`` times the reference well (n = 4, 15 states) and the same well split
into n = 8 segments (27 states), from a circulating steady state (1000 L/min, 20 bar choke
dp), and reports medians over many repetitions in milliseconds: the time update over one
0.1 s frame (steps_per_frame plant steps), the measurement update, and their sum as a
fraction of the frame. Target: under 10 % of real time.

    python -m drill_estimator.bench [config_dir]
"""
from __future__ import annotations

import json
import os
import sys
import time

import numpy as np

from drill_core import hydraulics as hy
from drill_core.config import RigConfig, load_rig, replace
from drill_core.operating_point import BENCH_POINT
from drill_core.rig_root import config_dir as default_config_dir
from drill_core.units import LPM_PER_M3S
from drill_estimator.ukf import RigUkf

CIRCULATION = BENCH_POINT.circulation_m3s
CHOKE_DP = BENCH_POINT.choke_dp_pa


def split_segments(lengths, parts: int) -> tuple[float, ...]:
    """Every segment cut into ``parts`` equal pieces (same depth, n * parts segments)."""
    return tuple(length / parts for length in lengths for _ in range(parts))


def _started_filter(config: RigConfig, jit: bool | None = None) -> tuple[RigUkf, np.ndarray, np.ndarray]:
    ukf = RigUkf(config, jit=jit)
    em, g, w = ukf.em, ukf.em.wm.geometry, ukf.em.wm.well
    rho_g = w.mud.density_kgm3 * w.gravity_mps2
    friction = 28.0e5 * CIRCULATION ** 2 / (1000.0 / LPM_PER_M3S) ** 2   # about the reference well's
    y = np.array([0.0, CHOKE_DP, w.choke_downstream_pressure_pa + CHOKE_DP + rho_g * g.node_depth_m[-1]
                  + friction, CIRCULATION])
    x0 = ukf.initial_state(y, True)
    ukf.initialise(x0)
    pump = x0[em.string_pressure] - rho_g * g.bit_depth_m \
        + float(hy.string_friction(np, em.wm, CIRCULATION, 0.0))
    block = g.static_stretch_m if ukf.block_input == "block_position" else 0.0
    return ukf, np.array([block, CIRCULATION, 0.0, pump]), y


def time_filter(config: RigConfig, repetitions: int = 300, jit: bool | None = None) -> dict[str, float]:
    """Median times [ms] for ``config``'s well of a frame's time update, its measurement
    update and the frame (the two in a row, timed apart in each repetition)."""
    start = time.perf_counter()
    ukf, u, y = _started_filter(config, jit)
    build_ms = (time.perf_counter() - start) * 1e3
    frame_inputs = np.repeat(u[:, None], config.plant.steps_per_frame, axis=1)
    for _ in range(20):                    # warm up
        ukf.predict_frame(frame_inputs)
        ukf.update(y, True)
    predict_s, update_s = np.empty(repetitions), np.empty(repetitions)
    for i in range(repetitions):           # a frame: its time update, then its measurement update
        start = time.perf_counter()
        ukf.predict_frame(frame_inputs)
        middle = time.perf_counter()
        ukf.update(y, True)
        predict_s[i], update_s[i] = middle - start, time.perf_counter() - middle
    predict_ms = float(np.median(predict_s) * 1e3)
    update_ms = float(np.median(update_s) * 1e3)
    frame_ms = float(np.median(predict_s + update_s) * 1e3)
    return {"states": float(ukf.n_x), "build_ms": build_ms, "frame_time_update_ms": predict_ms,
            "measurement_update_ms": update_ms, "frame_ms": frame_ms,
            "real_time_fraction": frame_ms * 1e-3 / config.plant.sensor_period_s,
            "finite": float(np.all(np.isfinite(ukf.mean)))}


def run_benchmark(config_dir: str | os.PathLike | None = None, repetitions: int = 300,
                  jit: bool | None = None) -> dict:
    """Timings for n = 4 and n = 8 (flat dict, keys prefixed ``ukf_n4_`` / ``ukf_n8_``).

    ``jit`` None follows config/estimator.yaml; True compiles the time update
    (drill_core.compiled: needs a C compiler, about a
    second once per configuration, cached)."""
    config = load_rig(config_dir or default_config_dir())
    out: dict[str, float] = {}
    for parts, tag in ((1, "n4"), (2, "n8")):
        cfg = config
        if parts > 1:
            cfg = replace(config, well=replace(config.well, segment_lengths_m=split_segments(
                config.well.segment_lengths_m, parts)))
        n = len(cfg.well.segment_lengths_m)
        for key, value in time_filter(cfg, repetitions, jit).items():
            out[f"ukf_n{n}_{key}"] = value
    return out


if __name__ == "__main__":
    print(json.dumps(run_benchmark(sys.argv[1] if len(sys.argv) > 1 else None), indent=2))
