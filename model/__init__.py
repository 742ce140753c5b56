"""Rocking-block models: the C sources of the FMU (model/c) and independent
Python reference models (model.reference)."""
