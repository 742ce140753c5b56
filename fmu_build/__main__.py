"""``python -m fmu_build``: build build/RockingBlock.fmu (FMI 2.0) and build/RockingBlock3.fmu (FMI 3.0)
from model/c, and build/ShearBuilding.fmu (the shear building, FMI 2.0 Co-Simulation) from model/c/building;
with --sanitize, the three with AddressSanitizer and UBSan (build/*-sanitize.fmu)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fmu_build.build import BuildError, build_fmu
from fmu_build.build3 import build_fmu3
from fmu_build.building import build_building_fmu


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m fmu_build", description=__doc__)
    parser.add_argument("--out", type=Path, help="output .fmu path (default build/RockingBlock.fmu)")
    parser.add_argument("--out3", type=Path, help="output path of the FMI 3.0 FMU (default build/RockingBlock3.fmu)")
    parser.add_argument("--sanitize", action="store_true", help="build with AddressSanitizer and UBSan")
    parser.add_argument("--force", action="store_true", help="rebuild even if the sources did not change")
    parser.add_argument("--platforms", type=lambda s: [p.strip() for p in s.split(",") if p.strip()],
                        metavar="LIST", help="comma-separated binaries to build, of linux64,win64 (default: "
                        "linux64, and win64 where the mingw-w64 cross compiler is installed); a platform named "
                        "here that cannot be built is an error")
    args = parser.parse_args(argv)
    try:
        path = build_fmu(args.out, sanitize=args.sanitize, force=args.force, platforms=args.platforms)
        path3 = build_fmu3(args.out3, sanitize=args.sanitize, force=args.force, platforms=args.platforms)
        building = build_building_fmu(force=args.force, platforms=args.platforms, sanitize=args.sanitize)
    except (BuildError, OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(path)
    print(path3)
    print(building)
    return 0


if __name__ == "__main__":
    sys.exit(main())
