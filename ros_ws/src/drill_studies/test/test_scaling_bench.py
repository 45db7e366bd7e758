"""The scaling bench's wells and arithmetic: n segments keep the well's depths, the fitted
exponent is the power law's, and the page section states each goal; the drilling section
names its bound."""
import pytest

from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_nmpc.prediction_model import nmpc_estimation_model
from drill_studies import scaling_bench
from drill_studies.bench import drilling_markdown


@pytest.fixture(scope="module")
def config():
    return load_rig(config_dir())


def test_four_segments_are_the_reference_well(config):
    lengths = config.well.segment_lengths_m
    assert scaling_bench.segment_lengths_m(lengths, 4) == pytest.approx(lengths, rel=1e-12)


@pytest.mark.parametrize("n", [6, 8, 12, 16])
def test_n_segments_keep_the_depth_the_shoe_and_the_open_hole(config, n):
    well = scaling_bench.segmented(config, n).well
    assert len(well.segment_lengths_m) == n
    assert sum(well.segment_lengths_m) == pytest.approx(sum(config.well.segment_lengths_m), rel=1e-12)
    assert sum(well.segment_lengths_m[:-1]) == pytest.approx(config.well.casing_shoe_depth_m)
    assert well.segment_lengths_m[-1] == config.well.segment_lengths_m[-1]
    well.validate()
    em = nmpc_estimation_model(scaling_bench.segmented(config, n), "NMPC1")
    assert em.wm.n == n


def test_fewer_than_two_segments_are_refused(config):
    with pytest.raises(ValueError, match="at least 2"):
        scaling_bench.segment_lengths_m(config.well.segment_lengths_m, 1)


def test_the_exponent_is_the_power_laws():
    counts = [4, 6, 8, 12, 16]
    assert scaling_bench.exponent(counts, [3.0 * n ** 1.7 for n in counts]) == pytest.approx(1.7)


def _row(n, k):
    row = {"n": n, "states": 3 * n + 4, "plant_frame_s": 1e-4 * n, "ukf_frame_s": 1e-4 * n ** 0.99,
           "ukf_time_update_s": 0.8e-4 * n ** 0.99, "ukf_measurement_update_s": 0.2e-4 * n ** 0.99,
           "solve_median_s": 1e-3 * n ** k, "solve_p99_s": 2e-3 * n ** k, "nmpc_build_s": 1.0,
           "graph_wall_s": 30.0 + n, "graph_rtf": 0.05, "graph_cpu_s": 40.0}
    parts = {"linearisation": 0.5 * n ** k, "qp": 0.3 * n ** 0.5, "evaluation": 0.1, "other": 0.1}
    return row | {f"{p}_s": 1e-3 * v for p, v in parts.items()}


@pytest.mark.parametrize("k, missed", [(0.9, False), (1.8, True)])
def test_the_section_states_each_goal_and_the_bound_of_a_missed_one(k, missed):
    rows = [_row(n, k) for n in scaling_bench.SEGMENT_COUNTS]
    scaling = {"rows": rows, "wall_ratio_6_4": rows[1]["graph_wall_s"] / rows[0]["graph_wall_s"],
               "exponents": scaling_bench.growth_exponents(rows)}
    text = "\n".join(scaling_bench.markdown(scaling))
    assert f"NMPC solve median k = {k:.2f} (goal: <= 1{': missed' if missed else ')'}" in text
    assert "UKF frame k = 0.99 (goal: <= 1)" in text
    assert "n = 6 is 1.06 times n = 4's (goal: <= 1.5)" in text
    assert ("What bounds the NMPC solve median's growth: the solve's linearisation, k = "
            f"{k:.2f}" in text) == missed
    assert "UKF frame's growth" not in text
    assert [line.split(" | ")[0] for line in text.splitlines() if line[2:3].isdigit()] == \
        [f"| {n}" for n in scaling_bench.SEGMENT_COUNTS]
    assert "| 16 | 52 |" in text


def test_the_drilling_section_names_the_fixed_cost_that_bounds_a_short_run():
    runs = [{"scenario": "long", "simulated_s": 70.0, "model_cpu_s": 0.4, "graph_wall_s": 5.7},
            {"scenario": "short", "simulated_s": 6.0, "model_cpu_s": 0.4, "graph_wall_s": 5.06}]
    text = "\n".join(drilling_markdown(runs))
    assert "| long | 70.00 s | 0.400 s | 175 | 5.7 s | 12.28 | 0.08 | met |" in text
    assert "| 0.84 | missed |" in text
    assert "short (6.0 s simulated: 3.0 s of wall allowed, its string model 0.40 s of CPU)" in text
    assert "costs at least 5.1 s whatever its simulated time (the shortest run here, short" in text
    assert "Goal" not in "\n".join(drilling_markdown(runs[:1]))


def test_a_figure_measured_at_or_below_zero_gets_no_exponent():
    rows = [_row(n, 1.0) for n in scaling_bench.SEGMENT_COUNTS]
    rows[2]["ukf_measurement_update_s"] = -1e-5
    exponents = scaling_bench.growth_exponents(rows)
    assert "ukf_measurement_update_s" not in exponents and "ukf_frame_s" in exponents
    assert scaling_bench.growth_exponents(rows[:1]) == {}
