"""The protection's measurement watch (drill_protection.watch): the block velocity over
the last second, a lost circulation raised once as an alarm and answered, the stop's BHP
median fed from every measurement."""
from types import SimpleNamespace

import numpy as np
import pytest

from drill_core import hydraulics as hy
from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_protection.protection import ProcessProtection
from drill_protection.watch import MeasurementWatch

CONFIG = config_dir()
FRAME_NS = 100_000_000


@pytest.fixture()
def watch():
    config = load_rig(CONFIG)
    wm = hy.rig_well_model(config)
    protection = ProcessProtection(config, wm, np.array([0.0, 0.0167, 0.0, 1.06e7]))
    return MeasurementWatch(config, wm, protection)


def sample(block_m: float, string_flow_valid: bool = True, bhp_pa: float = 6.85e7):
    return SimpleNamespace(return_flow_m3s=0.0167, string_flow_m3s=0.0167,
                           string_flow_valid=string_flow_valid, bpp_flow_m3s=0.0,
                           block_position_m=block_m, choke_dp_pa=2.0e6, bhp_pa=bhp_pa,
                           pit_volume_m3=0.0)


def test_the_block_velocity_is_over_the_last_second(watch):
    for k in range(30):                                  # 0.4 m/s for 3 s
        watch.observe(k * FRAME_NS, sample(0.04 * k))
    assert watch.velocity_mps == pytest.approx(0.4)
    assert watch.positions[-1][0] - watch.positions[0][0] == 10 * FRAME_NS


def test_a_lost_circulation_is_raised_once_and_answered(watch):
    watch.circulation.request(True, 1.06e7)
    codes = []
    for k in range(20):
        codes += [n.code for n in watch.observe(k * FRAME_NS, sample(0.0, string_flow_valid=k < 10))]
    assert codes == ["circulation_lost"] and watch.alarm_count == 1
    assert watch.circulation.action(2.0) is not None      # the protection answers it


def test_the_stops_bhp_reading_is_fed_from_every_measurement(watch):
    for k, bhp in enumerate((6.851e7, 6.849e7, 6.850e7, 6.853e7, 6.870e7)):
        watch.observe(k * FRAME_NS, sample(0.0, bhp_pa=bhp))
    assert watch.protection.bhp_gauge.median == 6.851e7
