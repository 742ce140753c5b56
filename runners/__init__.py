"""Runners: build scenes, run them through RockingBlock.fmu, report results."""
