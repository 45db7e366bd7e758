"""A run directory keeps the configuration it ran with, and the report judges the run with
that copy: a detector threshold changed in the checkout after the run does not change the
run's figures."""
import pytest
import yaml

from drill_analysis import report
from drill_bringup import runs
from drill_core.config import ConfigError, load_rig


def test_the_copy_is_the_checkouts_configuration_and_the_report_reads_it(tmp_path):
    copy = runs.stage_config(tmp_path)
    names = sorted(p.name for p in (runs.ROOT / "config").glob("*.yaml"))
    assert sorted(p.name for p in copy.iterdir()) == names
    assert all((copy / n).read_bytes() == (runs.ROOT / "config" / n).read_bytes() for n in names)
    assert report.run_config_dir(tmp_path) == copy
    protection = yaml.safe_load((copy / "protection.yaml").read_text())
    protection["kick_detection"]["flow_threshold_m3s"] = 0.0123
    (copy / "protection.yaml").write_text(yaml.safe_dump(protection))
    assert load_rig(report.run_config_dir(tmp_path)).protection.kick_detection \
        .flow_threshold_m3s == 0.0123


def test_a_run_without_a_copy_is_judged_with_the_checkouts(tmp_path):
    assert report.run_config_dir(tmp_path) == runs.ROOT / "config"
    assert report.run_config_dir(None) == runs.ROOT / "config"


def test_an_unknown_scenario_is_a_configuration_error_naming_the_known_ones():
    """Library callers (a notebook, a study) get an exception they can catch, not an exit."""
    with pytest.raises(ConfigError, match=r"unknown scenario 'nope'; known: .*case2"):
        runs.scenario_path("nope")
