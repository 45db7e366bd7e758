"""The NMPC's prediction state: the estimation model's evolving states in their order, then
the actuator outputs whose lag is modelled, each found by name."""

from drill_core.config import load_rig
from drill_core.rig_root import config_dir
from drill_nmpc.prediction_model import ActuatorLags, PredictionModel, nmpc_estimation_model

CONFIG_DIR = config_dir()


def test_the_lagged_outputs_follow_the_models_states_in_order():
    em = nmpc_estimation_model(load_rig(CONFIG_DIR), "NMPC1")
    model = PredictionModel(em, ActuatorLags(drawworks_s=4.0, bpp_s=30.0, pump_s=5.0))
    assert model.layout.names[:model.nd_model] == em.names[:em.theta(2)]
    assert (model.block, model.bpp, model.pump) == (em.theta(2), em.theta(2) + 1, em.theta(2) + 2)
    assert model.nd == em.theta(2) + 3


def test_an_unmodelled_lag_has_no_state():
    em = nmpc_estimation_model(load_rig(CONFIG_DIR), "NMPC1")
    model = PredictionModel(em, ActuatorLags(drawworks_s=4.0, bpp_s=None, pump_s=5.0))
    assert model.bpp is None
    assert (model.block, model.pump, model.nd) == (em.theta(2), em.theta(2) + 1, em.theta(2) + 2)
    assert model.layout.names[model.pump] == "spp_output_pa"
