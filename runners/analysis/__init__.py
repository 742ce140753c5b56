"""Analysis built on the engine: fragility and IDA fits, overturning maps, work-precision and
stability charts, the least-model choice, comparison with and calibration to measurements,
benchmarks and the figures in docs/figures."""
