"""CasADi nonlinear MPC supervisor and its node."""
