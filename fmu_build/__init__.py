"""Build RockingBlock.fmu (FMI 2.0 Co-Simulation) from the C sources in model/c.

``python -m fmu_build`` compiles the sources with the system C compiler
against the FMI 2.0 headers shipped in the installed fmpy package and packs
modelDescription.xml, the Linux binary and the sources into build/RockingBlock.fmu.
"""

from fmu_build.build import MODEL_IDENTIFIER, build_fmu, default_fmu_path

__all__ = ["MODEL_IDENTIFIER", "build_fmu", "default_fmu_path"]
