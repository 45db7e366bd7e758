"""Truth plant (stochastic wellbore hydraulics + hoisting) and actuator nodes."""
