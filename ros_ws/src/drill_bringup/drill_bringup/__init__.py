"""Launcher, split runs, the rig CLI, reports, comparisons, sweeps and the in-process benches."""
