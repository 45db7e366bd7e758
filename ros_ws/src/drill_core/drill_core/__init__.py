"""Plain-Python core of the rig: typed configuration, well description, rheology, the shared wellbore model, integrators, the open-loop command sequence."""
