"""The NMPC's tick on a multi-stand trip (no solve): what the rig floor pins over the
horizon and the setpoints it plans with, phase by phase."""
import math

import numpy as np
import pytest

from drill_core.config import load_rig
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_PUMP_PRESSURE
from drill_core.rig_root import config_dir
from drill_core.scenario import ActiveSetpoints
from drill_core.tripping.programme import TripProgramme
from drill_core.tripping.rig_floor import FloorCommand
from drill_core.tripping.sequence import (CONNECTION, MOVING, PUMP_DOWN, SET_SLIPS, TripStep,
                                          pump_factor_ahead)
from drill_nmpc.advisor_ticks import CONNECTION_BPP_FLOW_M3S, NmpcTick, StartInputs
from drill_nmpc.prediction_model import nmpc_estimation_model

SPP_PA = 1.06e7
TRIP = TripProgramme(direction="out", stands=3)


@pytest.fixture(scope="module")
def tick():
    config = load_rig(config_dir())
    return NmpcTick(config, nmpc_estimation_model(config),
                    StartInputs(1000.0 / 60000.0, 2.0e6, 0.0, SPP_PA, True), trip=TRIP)


def _floor(phase, factor=1.0, pulled=1):
    return FloorCommand(TripStep(phase, 2, phase != MOVING, True, factor, 56.0, pulled),
                        math.nan, None, None)


def _setpoints():
    return ActiveSetpoints(bhp_ref_pa=6.85e7, bhp_band_pa=2.0e5, choke_dp_ref_pa=2.0e6,
                           choke_dp_band_pa=5.0e5, choke_dp_band_upper_pa=6.63e7,
                           block_position_target_m=math.nan, trip_speed_limit_mps=0.5,
                           controller_enabled=True, mud_pump_on=True)


def _estimate(tick, position_m):
    x = np.zeros(len(tick.em.names))
    x[tick.em.position] = position_m
    return x


def test_the_floor_pins_the_pump_ramp_and_holds_the_block_in_the_slips(tick):
    tick.u_prev = np.array([27.6, 0.0, 0.0, SPP_PA])
    sp, fixed = tick.floor_plan(_estimate(tick, 27.6), _setpoints(), _floor(MOVING), 100.0)
    assert sp.block_position_target_m == 28.0              # the stand's end, in its frame
    assert np.isnan(fixed[:, [U_BLOCK, 1, U_BPP_FLOW]]).all()
    assert (fixed[:, U_PUMP_PRESSURE] == SPP_PA).all()
    sp, fixed = tick.floor_plan(_estimate(tick, 27.9), _setpoints(), _floor(SET_SLIPS), 160.0)
    assert sp.block_position_target_m == 27.9 and (fixed[:, U_BLOCK] == 27.9).all()
    assert (fixed[:, U_BPP_FLOW] == CONNECTION_BPP_FLOW_M3S).all()   # its lag passes first
    tick.floor_plan(_estimate(tick, 27.9), _setpoints(), _floor(PUMP_DOWN), 170.0)
    sp, fixed = tick.floor_plan(_estimate(tick, 27.9), _setpoints(), _floor(PUMP_DOWN, 0.5),
                                185.0)
    ts = tick.supervisor.problem.ts
    expected = [SPP_PA * pump_factor_ahead(TRIP, PUMP_DOWN, 15.0, (k + 0.5) * ts)
                for k in range(len(fixed))]
    assert fixed[:, U_PUMP_PRESSURE] == pytest.approx(expected)
    assert fixed[0, U_PUMP_PRESSURE] == pytest.approx(SPP_PA * (1.0 - 15.5 / 30.0))
    assert fixed[-1, U_PUMP_PRESSURE] == pytest.approx(SPP_PA * 0.5 / 30.0)   # 29.5 s in
    assert np.isnan(fixed[:, U_BPP_FLOW]).all()
    share = tick.cfg.floor_pump_on_share          # the ramp planned with the pump on above it
    assert 0.0 < share < 1.0
    for factor, on in ((1.0, True), (share + 0.01, True), (share, False), (share - 0.01, False)):
        sp, _ = tick.floor_plan(_estimate(tick, 27.9), _setpoints(), _floor(PUMP_DOWN, factor),
                                190.0)
        assert sp.mud_pump_on is on
    sp, _ = tick.floor_plan(_estimate(tick, 27.9), _setpoints(), _floor(CONNECTION, 0.0), 200.0)
    assert not sp.mud_pump_on


def test_a_racked_stand_plans_on_the_new_strings_model_in_its_frame(tick):
    """The floor's stands pulled goes from 1 to 2 at the connection's end: the supervisor
    of the string 56 m short (its estimation model's string), the block's last input put
    at the string in its new frame, no warm start."""
    tick.floor_plan(_estimate(tick, 27.9), _setpoints(), _floor(CONNECTION, 0.0), 200.0)
    one = tick.supervisor
    assert tick.pulled_m == 28.0
    tick.u_prev = np.array([27.9, 0.0, 0.0, SPP_PA])
    tick.floor_plan(_estimate(tick, -0.1), _setpoints(), _floor(CONNECTION, 0.0, pulled=2),
                    210.0)
    assert tick.pulled_m == 56.0 and tick.supervisor is not one
    assert tick.supervisor.em.wm.geometry.bit_depth_m == pytest.approx(
        one.em.wm.geometry.bit_depth_m - 28.0)
    assert tick.u_prev[U_BLOCK] == -0.1 and tick.supervisor._warm is None


def test_the_trip_plans_with_the_stand_end_rows_and_the_back_pressure_pump_kept_running(
        tick, monkeypatch):
    """A trip's supervisors carry the stand_end rows, and every sample of the trip, moving
    or not, asks the back-pressure pump for the connection's flow (its 30 s lag is twice
    the horizon: it is there when the mud pump ramps down)."""
    asked = []
    for phase in (MOVING, SET_SLIPS, PUMP_DOWN, CONNECTION):
        tick.u_prev = np.array([27.9, 0.0, 0.0, SPP_PA])
        floor = _floor(phase, 0.0 if phase == CONNECTION else 1.0)
        sup = tick._supervisor_for(floor.step.stands_pulled * TRIP.stand_length_m)
        assert any("stand_end" in st.rows for st in sup.problem.stages)
        monkeypatch.setattr(sup, "step", lambda *a, **k: asked.append(k["bpp_reference_m3s"])
                            or sup.hold(tick.u_prev, "test"))
        tick.step(_estimate(tick, 27.9), _setpoints(), {}, floor, 300.0)
    assert asked == [CONNECTION_BPP_FLOW_M3S] * 4
