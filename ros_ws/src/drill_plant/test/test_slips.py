"""The slips and the elevator in the truth plant: set slips hold the string at rest while
the block slacks off, is unlatched and travels a stand's length free; latched again and
lifted, the string stays in the slips until the line carries its weight and then follows
the block, the line's pull rising without a jump (drill_core.tripping.hoist is the same
rule on its own)."""

import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.hydraulics import rig_well_model
from drill_core.rig_root import config_dir
from drill_core.tripping.hoist import buoyed_weight_n
from drill_plant import plant_model as pm
from drill_plant.simulator import PlantSimulator

FLOW_M3S = 1000.0 / 60000.0


class _Floor:
    """The plant circulating at a fixed choke, the block moved at a speed per frame."""

    def __init__(self):
        cfg = load_rig(config_dir())
        wm = rig_well_model(cfg)
        self.sim = PlantSimulator(cfg, pm.steady_state(wm, FLOW_M3S, 2.0e6, 0.0), seed=4)
        self.steps, self.step_s = self.sim.steps_per_frame, cfg.plant.step_s
        self.u = self.sim.inputs.copy()
        self.weight_n = buoyed_weight_n(self.sim.wm.geometry, cfg.well.gravity_mps2)
        self.log = []                                   # (block, string, velocity, tension)

    def move(self, speed_mps: float, seconds: float, until=None) -> None:
        for _ in range(int(round(seconds / (self.steps * self.step_s)))):
            rows = np.repeat(self.u[:, None], self.steps, axis=1)
            rows[0] = self.u[0] + speed_mps * self.step_s * np.arange(1, self.steps + 1)
            self.u[0] = rows[0, -1]
            self.sim.advance(rows)
            lay = self.sim.layout
            self.log.append((self.u[0], self.sim.state[lay.position],
                             self.sim.state[lay.velocity], self.sim.line_tension_n()))
            if until is not None and until(self.log[-1]):
                return


@pytest.fixture(scope="module")
def floor():
    f = _Floor()
    f.move(0.0, 2.0)
    f.sim.set_hoisting(latched=True, slips_set=True)
    f.move(-0.2, 20.0, until=lambda row: row[3] <= 0.0)          # slack off onto the slips
    f.held_at_m = f.sim.state[f.sim.layout.position]
    f.slack_frame = len(f.log)
    f.sim.set_hoisting(latched=False, slips_set=True)
    f.move(-0.5, 56.0)                                            # the block down a stand
    f.free_frame = len(f.log)
    f.hook_free_n = f.sim.measure(circulating=True).hook_load_n
    f.move(0.5, 56.0)                                             # and back up to the top
    f.sim.set_hoisting(latched=True, slips_set=True)
    f.latch_frame = len(f.log)
    f.move(0.1, 40.0)                                             # pick up
    f.hook_lifting_n = f.sim.measure(circulating=True).hook_load_n
    return f


def test_the_hook_load_reads_the_block_alone_off_the_string_and_the_string_on_it(floor):
    """Within four of the load cell's standard deviations (and, lifting, the line's
    residual swing about the weight, under 1 kN here)."""
    cfg = floor.sim.config
    block_n, sigma_n = cfg.well.travelling_block_weight_n, cfg.plant.surface_sensor_noise.hook_load_n
    assert floor.hook_free_n == pytest.approx(block_n, abs=4.0 * sigma_n)
    assert floor.hook_lifting_n == pytest.approx(block_n + floor.weight_n, abs=4.0 * sigma_n + 1.0e3)


def test_set_slips_hold_the_string_while_the_block_slacks_off_and_travels(floor):
    log = np.array(floor.log)
    held = log[:floor.latch_frame]
    assert floor.weight_n > 5.0e5                                 # a string worth holding
    assert np.abs(held[:, 1] - floor.held_at_m).max() < 1.0e-3    # [m]
    assert np.abs(held[floor.slack_frame:, 2]).max() < 1.0e-4     # at rest [m/s]
    assert np.all(held[floor.slack_frame:, 3] == 0.0)             # unlatched: no pull
    block = log[floor.slack_frame:floor.free_frame, 0]
    assert block[0] - block[-1] == pytest.approx(28.0, abs=0.1)   # the block went a stand


def test_picking_up_lifts_the_string_once_the_line_carries_its_weight(floor):
    log = np.array(floor.log)[floor.latch_frame:]
    block, string, velocity, tension = log.T
    takes_weight = np.argmax(tension >= floor.weight_n - 1.0)
    lifted = np.argmax(string > floor.held_at_m + 1.0e-3)
    assert takes_weight > 0 and tension[0] < 0.05 * floor.weight_n     # latched slack
    # in the slips until the pull reaches the weight, off them within a second after
    assert np.abs(string[:takes_weight] - floor.held_at_m).max() < 1.0e-3
    assert takes_weight <= lifted <= takes_weight + 10
    frame_rise_n = floor.sim.wm.geometry.axial_stiffness_n_m * 0.1 * 0.1
    # the pull never jumps: per frame no more than the block's stretch of the line allows
    assert np.abs(np.diff(tension)).max() < 2.0 * frame_rise_n
    # lifted, the string follows the block at its speed
    assert velocity[-100:].mean() == pytest.approx(0.1, rel=0.05)
    assert np.all(np.isfinite(floor.sim.state))
