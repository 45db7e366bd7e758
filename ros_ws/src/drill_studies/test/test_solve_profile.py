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
