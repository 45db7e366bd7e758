"""``rig stability``: the printed analysis of the 36" string with n = 2 carries Paper IV's
worked numbers (section 4.2), and ``--output`` writes the three figures."""
import re

import pytest

from drill_rig import cli
from drill_string.stability import axial_stability
from drill_string.stability_command import write_figures

# Paper IV section 4.2, 36" section, n = 2: eigenfrequencies and the four crossing
# frequencies (scaled), the first destabilising; d_hat about 1.55e-5
PAPER_EIGENFREQUENCIES = (5.1392, 1.9630)
PAPER_CROSSINGS = (15.7675, 5.1392, 4.442, 1.9630)


def _printed(capsys, *argv) -> str:
    assert cli.main(["stability", *argv]) == 0
    return capsys.readouterr().out


def test_36in_with_two_elements_prints_the_papers_numbers(capsys):
    out = _printed(capsys, "36in", "--elements", "2")
    eigen = re.search(r"eigenfrequencies omega_j \(1/t\*\): (.*)", out).group(1)
    assert [float(v) for v in eigen.split(",")] == pytest.approx(PAPER_EIGENFREQUENCIES, abs=1e-4)
    rows = re.findall(r"^\| ([\d.]+) \| ([+-]) \| ([\d.]+) \| (.*) \|$", out, re.M)
    assert [float(r[0]) for r in rows] == pytest.approx(PAPER_CROSSINGS, abs=1e-3)
    assert [r[1] for r in rows] == ["+", "-", "+", "-"]     # the first crossing destabilises
    # omega_1* repeats three times before the first stabilising switch (docs/drilling.md 3.2)
    assert [float(d) for d in rows[0][3].split(",")] == pytest.approx([0.1992, 0.5977, 0.9962],
                                                                        abs=1e-4)
    assert float(re.search(r"d_hat = ([\d.e+-]+)", out).group(1)) == pytest.approx(1.55e-5,
                                                                                rel=0.01)
    assert re.search(r"delay margin\s+0\.1992 t\*", out)
    assert re.search(r"critical speed\s+797\.6 rpm", out)
    assert re.search(r"stable speeds \(rpm\)\s+> 797\.6$", out, re.M)


def test_12in_with_bha_prints_the_stable_pocket(capsys):
    out = _printed(capsys, "12.25in", "--elements", "6", "--bha")
    assert re.search(r"critical speed\s+151\.9 rpm", out)
    assert re.search(r"stable speeds \(rpm\)\s+75\.7-77\.5, > 151\.9$", out, re.M)


def test_bad_arguments_are_refused(capsys):
    assert cli.main(["stability", "37in", "--elements", "2"]) == 2
    assert cli.main(["stability", "36in", "--elements", "0"]) == 2
    assert "37in" in capsys.readouterr().err


def test_output_writes_the_three_figures(tmp_path):
    paths = write_figures(axial_stability("36in", 2), tmp_path, ns=(1, 2))
    assert [p.name for p in paths] == ["fig3_critical_speed_uniform.png",
                                       "fig4_critical_speed_bha.png", "fig7_stability_map.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)
