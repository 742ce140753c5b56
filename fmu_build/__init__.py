"""Build RockingBlock.fmu (FMI 2.0 Co-Simulation) from the C sources in model/c.

``python -m fmu_build`` compiles the sources with the system C compiler
against the FMI 2.0 headers shipped in the installed fmpy package and packs
modelDescription.xml, the Linux binary and the sources into build/RockingBlock.fmu;
then the FMI 3.0 edition, build/RockingBlock3.fmu (fmu_build.build3), from the same core.
"""

from fmu_build.build import MODEL_IDENTIFIER, build_fmu, default_fmu_path
from fmu_build.build3 import MODEL_IDENTIFIER3, build_fmu3, default_fmu3_path

__all__ = ["MODEL_IDENTIFIER", "MODEL_IDENTIFIER3", "build_fmu", "build_fmu3", "default_fmu_path", "default_fmu3_path"]
