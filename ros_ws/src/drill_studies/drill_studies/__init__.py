"""Studies over many runs: the runner of many graphs (drill_studies.batch), the
comparison, seed sweeps, the fault matrix, the benches, the in-process loop bench and
the ladders built on it, the emergency-stop study and re-estimation."""
