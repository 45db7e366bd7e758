"""Launcher, MCAP recorder and replay, scenarios and reports."""
