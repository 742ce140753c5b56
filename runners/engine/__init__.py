"""The engine: scenes, the FMU, sweeps, ground-motion records, summaries and Rerun recordings."""
