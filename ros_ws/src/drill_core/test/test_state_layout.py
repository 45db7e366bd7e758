"""The named layouts hold the paper's state order (Paper I eqs. 45-48 for the estimation
model; the truth plant without the block integral, plus its three volumes)."""

import numpy as np
import pytest

from drill_core.config import InputVector, load_rig
from drill_core.estimation_model import build_estimation_model
from drill_core.input_layout import (COMMAND_NAMES, U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE,
                                     U_SIZE)
from drill_core.rig_root import config_dir
from drill_msgs.msg import RigCommand
from drill_plant.plant_model import PlantLayout

CONFIG_DIR = config_dir()


@pytest.mark.parametrize("n", [1, 3, 6])
def test_plant_layout_is_the_papers_order(n):
    lay = PlantLayout(n)
    assert (lay.position, lay.velocity) == (0, 1)
    assert [lay.pressure(i) for i in range(1, n + 1)] == [2 * i for i in range(1, n + 1)]
    assert [lay.flow(i) for i in range(2, n + 1)] == [2 * i - 1 for i in range(2, n + 1)]
    assert (lay.string_flow, lay.string_pressure) == (2 * n + 1, 2 * n + 2)
    assert (lay.hydraulic_size, lay.pit_gain, lay.loss_volume, lay.size) == \
        (2 * n + 3, 2 * n + 3, 2 * n + 5, 2 * n + 6)


@pytest.mark.parametrize("disturbance", [False, True])
def test_estimation_layout_is_the_papers_order(disturbance):
    em = build_estimation_model(load_rig(CONFIG_DIR), with_disturbance=disturbance)
    n = em.n
    # x = [z1, z2, z3, p_1, q_2, p_2, ..., q_n, p_n, q_d, p_I, theta_2..theta_n, delta_rho
    #      (, kappa_beta, d: the influx comes with the bulk modulus factor)]
    assert (em.position, em.velocity, em.block_integral) == (0, 1, 2)
    assert [em.pressure(i) for i in range(1, n + 1)] == [1 + 2 * i for i in range(1, n + 1)]
    assert [em.flow(i) for i in range(2, n + 1)] == [2 * i for i in range(2, n + 1)]
    assert (em.string_flow, em.string_pressure) == (2 * n + 2, 2 * n + 3)
    assert [em.theta(i) for i in range(2, n + 1)] == [2 * n + 2 + i for i in range(2, n + 1)]
    assert em.density_offset == 3 * n + 3
    assert em.size == 3 * n + 4 + 2 * int(disturbance)
    if disturbance:
        assert (em.bulk_modulus, em.disturbance) == (em.size - 2, em.size - 1)


def test_vector_moves_states_by_name_between_layouts():
    em = build_estimation_model(load_rig(CONFIG_DIR))
    lay = PlantLayout(em.n)
    x = np.arange(lay.size, dtype=float)
    values = {**dict(zip(lay.names, x)), "block_integral_m_s": -1.0, "density_offset_kgm3": 2.0,
              **{em.theta_name(i): 100.0 + i for i in range(2, em.n + 1)}}
    x_hat = em.vector(values)
    assert x_hat[em.pressure(em.n)] == x[lay.pressure(em.n)]
    assert x_hat[em.string_flow] == x[lay.string_flow]
    assert x_hat[em.block_integral] == -1.0
    assert x_hat[em.theta(em.n)] == 100.0 + em.n
    del values["block_integral_m_s"]
    with pytest.raises(KeyError, match="block_integral_m_s"):
        em.vector(values)
    with pytest.raises(KeyError, match="no state 'pit_gain_m3'"):
        em.index("pit_gain_m3")


def test_the_input_layout_is_the_command_messages_order():
    """u's entries sit where the rig command message and the NMPC's input limits list them:
    the message's first four fields, and the config's per-input vectors field by field."""
    fields = list(RigCommand.get_fields_and_field_types())
    assert tuple(fields[1:1 + U_SIZE]) == COMMAND_NAMES          # after the header
    positions = {name: i for i, name in enumerate(COMMAND_NAMES)}
    assert (positions["block_position_ref_m"], positions["choke_flow_ref_m3s"],
            positions["bpp_flow_m3s"], positions["spp_pa"]) == \
        (U_BLOCK, U_CHOKE, U_BPP_FLOW, U_PUMP_PRESSURE)
    vector = InputVector(block_position_m=10.0, choke_flow_m3s=20.0, bpp_flow_m3s=30.0,
                         spp_pa=40.0).as_tuple()
    assert (vector[U_BLOCK], vector[U_CHOKE], vector[U_BPP_FLOW], vector[U_PUMP_PRESSURE]) == \
        (10.0, 20.0, 30.0, 40.0)
