"""The bench's NMPC profile: the parts of a real-time-iteration solve add up to the solves'
time, each part was timed, and its page section names every part and the goal."""
import pytest

from drill_nmpc.bench import solve_profile
from drill_nmpc.transcription import RTI_PARTS
from drill_studies.bench import solve_profile_markdown


@pytest.fixture(scope="module")
def profile():
    return solve_profile(samples=12)


def test_the_parts_add_up_to_the_solves(profile):
    parts = [*RTI_PARTS, "other"]
    assert sum(profile[f"{p}_share"] for p in parts) == pytest.approx(1.0, abs=1e-9)
    assert all(profile[f"{p}_s_per_solve"] > 0.0 for p in RTI_PARTS)
    assert profile["other_s_per_solve"] >= 0.0
    assert profile["qp_and_compiled_share"] == pytest.approx(1.0 - profile["other_share"])
    assert 0.0 < profile["median_solve_s"]


def test_the_page_section_names_every_part_and_the_goal(profile):
    text = "\n".join(solve_profile_markdown(profile))
    for part in [*RTI_PARTS, "other"]:
        assert f"| {part} |" in text
    assert "goal: >= 80%" in text
    missed = {**profile, "qp_and_compiled_share": 0.5}
    assert "goal: >= 80%: missed" in "\n".join(solve_profile_markdown(missed))


def test_the_peer_table_gives_the_ratio_and_its_goal():
    from drill_studies.bench import peers_markdown
    row = {"median_s": 0.01, "p99_s": 0.02, "max_s": 0.03, "bhp_rmse_pa": 2.0e4,
           "bhp_max_error_pa": 5.0e4, "fallbacks": 0, "build_s": 1.0}
    peers = {"samples": 150, **{f"project_{k}": v for k, v in row.items()},
             **{f"do_mpc_{k}": (v * 12 if k == "median_s" else v) for k, v in row.items()}}
    text = "\n".join(peers_markdown(peers))
    assert "12.0 times faster" in text and "goal: >= 20: missed" in text
    assert "| 120.0 ms |" in text and "| 10.0 ms |" in text
    assert "Not in the comparison: GEKKO" in text


def test_a_missed_speed_up_is_set_against_the_solves_own_parts(profile):
    from drill_studies.bench import peers_markdown
    row = {"median_s": profile["median_solve_s"], "p99_s": 0.02, "max_s": 0.03,
           "bhp_rmse_pa": 2.0e4, "bhp_max_error_pa": 5.0e4, "fallbacks": 0, "build_s": 1.0}
    peers = {"samples": 150, **{f"project_{k}": v for k, v in row.items()},
             **{f"do_mpc_{k}": (v * 10 if k == "median_s" else v) for k, v in row.items()}}
    compiled_ms = sum(profile[f"{p}_s_per_solve"] for p in RTI_PARTS) * 1e3
    text = "\n".join(peers_markdown(peers, profile))
    assert f"needs a median solve of {profile['median_solve_s'] * 10 / 20 * 1e3:.1f} ms" in text
    assert f"alone take {compiled_ms:.1f} ms" in text
    met = {**peers, "do_mpc_median_s": profile["median_solve_s"] * 25}
    assert "What bounds it" not in "\n".join(peers_markdown(met, profile))


def test_the_arithmetic_floor_is_the_runs_frames_and_solves_at_their_bench_cost():
    from drill_studies.bench import arithmetic_floor, floor_markdown
    results = {"plant": {"plant_frame_median_s": 0.4e-3}, "estimator": {"ukf_n4_frame_ms": 1.0},
               "nmpc": {"nmpc1_median_s": 0.01},
               "graph": [{"default": False, "simulated_s": 600.0, "budget": [{"cpu_s": 99.0, "executor_s": 0.0,
                                                                        "compute_s": 99.0, "publish_s": 0.0,
                                                                        "preempted_s": 0.0}]},
                         {"default": True, "layout": "two", "simulated_s": 600.0,
                          "budget": [{"cpu_s": 20.0, "executor_s": 3.0, "compute_s": 16.0,
                                      "publish_s": 1.0, "preempted_s": 0.5},
                                     {"cpu_s": 10.0, "executor_s": 2.0, "compute_s": 7.0,
                                      "publish_s": 1.0, "preempted_s": 0.0}]}]}
    floor = arithmetic_floor(results, 0.1, 1.0)
    assert floor["floor_s"] == pytest.approx(6000 * 0.4e-3 + 6000 * 1.0e-3 + 600 * 0.01)   # 14.4 s
    assert floor["cpu_s"] == 30.0 and floor["ratio"] == pytest.approx(30.0 / 14.4)
    text = "\n".join(floor_markdown(floor))
    assert "= 14.4 s of CPU" in text and "2.08 times that floor (goal: <= 2: missed" in text
    assert ("the goal allows 28.8 s; over the floor's 14.4 s the processes spent 5.0 s in "
            "their executors and DDS, 2.0 s publishing and 8.6 s of callback compute") in text
    assert arithmetic_floor({"graph": results["graph"]}, 0.1, 1.0) is None
