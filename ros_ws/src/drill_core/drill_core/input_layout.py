"""The input vector u: four entries in one order, shared by every model and command.

The truth plant, the estimation model, the NMPC's prediction model and the rig command
each take a four-entry u in the same order; the block and choke entries mean a different
machine quantity in each (docs/model.md, "State layouts"):

| entry | truth plant | estimation model | NMPC, rig command |
| --- | --- | --- | --- |
| ``U_BLOCK`` | drawworks output u_b [m] | block reference u_r or output u_b [m] | block reference [m] |
| ``U_CHOKE`` | choke opening [1] | choke flow q_c [m^3/s] | choke flow reference [m^3/s] (or choke-dp set-point [Pa]) |
| ``U_BPP_FLOW`` | back-pressure pump flow [m^3/s] | the same | the same |
| ``U_PUMP_PRESSURE`` | stand-pipe pressure [Pa] | the same | the same |

Every read or write of an entry goes through these positions.
"""
from __future__ import annotations


U_BLOCK = 0
U_CHOKE = 1
U_BPP_FLOW = 2
U_PUMP_PRESSURE = 3
U_SIZE = 4


# The rig command's entries by name, as its message fields and the protection's notices
# spell them (drill_msgs/RigCommand).
COMMAND_NAMES = ("block_position_ref_m", "choke_flow_ref_m3s", "bpp_flow_m3s", "spp_pa")
