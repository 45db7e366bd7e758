"""Unscented Kalman filter for states and annular friction parameters, and its node."""
