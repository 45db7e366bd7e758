"""What the actuators' frames tell the NMPC: each frame's last output under its key, the
drawworks' block controller command and reference with it, the choke's frame not read."""
import numpy as np

from drill_nmpc.prediction_model import measured_actuators
from drill_plant.actuators import FrameOutput


def test_each_frame_gives_its_last_output_and_the_drawworks_its_controller():
    frames = {"drawworks": FrameOutput(12.5, 12.0, np.array([11.0, 11.9])),
              "choke": FrameOutput(0.3, 0.3, np.array([0.2, 0.25])),
              "bpp": FrameOutput(0.01, 0.01, np.array([0.004, 0.005])),
              "mud_pump": FrameOutput(1.0e7, 1.0e7, np.array([9.0e6, 9.5e6]))}
    assert measured_actuators(frames) == {
        "block_m": 11.9, "block_command_m": 12.5, "block_reference_m": 12.0,
        "bpp_flow_m3s": 0.005, "spp_pa": 9.5e6}
    assert measured_actuators({}) == {}
