"""The database schema (SQLAlchemy 2, declarative). Units SI, angles in radians
(docs/conventions.md). Every table change goes with an Alembic migration in
db/migrations/versions."""

from __future__ import annotations

from datetime import datetime, timezone

from sqlalchemy import JSON, Boolean, DateTime, Float, ForeignKey, Integer, LargeBinary, String, Text, \
    UniqueConstraint
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


def _now() -> datetime:
    return datetime.now(timezone.utc)


class Base(DeclarativeBase):
    pass


class Block(Base):
    """A rectangular block: half width and half height (m), mass (kg), material, restitution."""

    __tablename__ = "blocks"
    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    half_width: Mapped[float] = mapped_column(Float)
    half_height: Mapped[float] = mapped_column(Float)
    mass: Mapped[float] = mapped_column(Float)
    material: Mapped[str | None] = mapped_column(String(100))
    restitution_law: Mapped[str] = mapped_column(String(20), default="housner")  # housner, modified, constant
    k: Mapped[float | None] = mapped_column(Float)  # impact position, modified law
    k_size_average: Mapped[float | None] = mapped_column(Float)  # Čeh & Jelenić (2022): the average k of its size class
    eta: Mapped[float | None] = mapped_column(Float)  # constant law
    correction: Mapped[float] = mapped_column(Float, default=1.0)
    source: Mapped[str | None] = mapped_column(Text)


class Record(Base):
    """A ground-motion record: its samples (time in s, horizontal and optionally vertical ground
    acceleration in m/s^2, our signs; db.series), where it comes from, and its intensity
    measures, computed once from the samples joined by straight lines (runners.engine.intensity)."""

    __tablename__ = "records"
    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200), unique=True)  # e.g. fema-p695/nearfield_pulse/1a
    suite: Mapped[str | None] = mapped_column(String(100), index=True)  # e.g. fema-p695/nearfield_pulse
    event: Mapped[str | None] = mapped_column(String(200))  # e.g. Imperial Valley-06
    year: Mapped[int | None] = mapped_column(Integer)
    magnitude: Mapped[float | None] = mapped_column(Float)  # moment magnitude
    station: Mapped[str | None] = mapped_column(String(200))
    distance_km: Mapped[float | None] = mapped_column(Float)  # closest distance to the rupture plane, km
    component: Mapped[str | None] = mapped_column(String(100))  # e.g. IMPVALL/H-E06_233
    source: Mapped[str | None] = mapped_column(Text)  # provenance: who recorded, processed and published it
    meta: Mapped[dict | None] = mapped_column(JSON)  # everything else the source states
    file_name: Mapped[str | None] = mapped_column(Text)
    names: Mapped[list] = mapped_column(JSON)  # ["ah"] or ["ah", "av"] (db.series, after time)
    n_samples: Mapped[int] = mapped_column(Integer)
    data: Mapped[bytes] = mapped_column(LargeBinary)  # db.series: time then columns
    sha256: Mapped[str] = mapped_column(String(64))  # of the samples (little-endian float64 time, then columns)
    dt: Mapped[float] = mapped_column(Float)  # s, smallest sample interval
    duration: Mapped[float] = mapped_column(Float)  # s, last sample time minus the first
    # intensity measures of the horizontal component (runners.engine.intensity); None until computed
    pga: Mapped[float | None] = mapped_column(Float)  # m/s^2
    pgv: Mapped[float | None] = mapped_column(Float)  # m/s
    pgd: Mapped[float | None] = mapped_column(Float)  # m
    arias: Mapped[float | None] = mapped_column(Float)  # m/s, Arias intensity
    d5_95: Mapped[float | None] = mapped_column(Float)  # s, significant duration
    mean_period: Mapped[float | None] = mapped_column(Float)  # s
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=_now)


class Excitation(Base):
    """A parametric excitation (the FMU's built-in waveforms) or a stored record times a scale."""

    __tablename__ = "excitations"
    id: Mapped[int] = mapped_column(primary_key=True)
    # none, sine-pulse, cosine-pulse, harmonic, record, ricker, ricker-antisymmetric, mavroeidis-papageorgiou
    kind: Mapped[str] = mapped_column(String(30))
    amplitude: Mapped[float | None] = mapped_column(Float)  # m/s^2
    frequency: Mapped[float | None] = mapped_column(Float)  # Hz
    cycles: Mapped[float | None] = mapped_column(Float)
    start_time: Mapped[float | None] = mapped_column(Float)  # s
    vertical_amplitude: Mapped[float | None] = mapped_column(Float)  # m/s^2
    displacement: Mapped[float | None] = mapped_column(Float)  # m
    gamma: Mapped[float | None] = mapped_column(Float)  # Mavroeidis-Papageorgiou gamma
    phase: Mapped[float | None] = mapped_column(Float)  # rad, Mavroeidis-Papageorgiou nu
    record_id: Mapped[int | None] = mapped_column(ForeignKey("records.id"), index=True)
    scale: Mapped[float | None] = mapped_column(Float)  # multiplier of the record's accelerations
    record: Mapped[Record | None] = relationship()


class Scene(Base):
    """One block or a stack, its initial state and the FMU parameters that define the run."""

    __tablename__ = "scenes"
    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    n_blocks: Mapped[int] = mapped_column(Integer, default=1)
    block1_id: Mapped[int | None] = mapped_column(ForeignKey("blocks.id"))
    block2_id: Mapped[int | None] = mapped_column(ForeignKey("blocks.id"))
    parameters: Mapped[dict] = mapped_column(JSON)  # FMU parameter name -> value
    source: Mapped[str | None] = mapped_column(Text)  # the scene file's text
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=_now)


class Sweep(Base):
    """A grid of runs over one scene."""

    __tablename__ = "sweeps"
    __table_args__ = {"sqlite_autoincrement": True}  # ids never reused after a delete (revision 0012)
    id: Mapped[int] = mapped_column(primary_key=True)
    scene_id: Mapped[int] = mapped_column(ForeignKey("scenes.id"))
    grid: Mapped[dict] = mapped_column(JSON)
    total: Mapped[int] = mapped_column(Integer)
    done: Mapped[int] = mapped_column(Integer, default=0)
    status: Mapped[str] = mapped_column(String(20), default="running")
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=_now)


class Run(Base):
    """One simulation: what ran (model, method, tolerances, FMU and code versions) and how it went."""

    __tablename__ = "runs"
    __table_args__ = (UniqueConstraint("sweep_id", "grid_index", name="one_run_per_grid_point"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    scene_id: Mapped[int] = mapped_column(ForeignKey("scenes.id"))
    excitation_id: Mapped[int | None] = mapped_column(ForeignKey("excitations.id"))
    sweep_id: Mapped[int | None] = mapped_column(ForeignKey("sweeps.id"))
    grid_index: Mapped[int | None] = mapped_column(Integer)
    point: Mapped[dict | None] = mapped_column(JSON)  # the grid values of a sweep's run
    model: Mapped[str] = mapped_column(String(100))
    method: Mapped[str] = mapped_column(String(50))
    rel_tol: Mapped[float | None] = mapped_column(Float)
    abs_tol: Mapped[float | None] = mapped_column(Float)
    stop_time: Mapped[float] = mapped_column(Float)
    fmu_sha256: Mapped[str | None] = mapped_column(String(64))
    code_version: Mapped[str] = mapped_column(String(40))
    wall_time: Mapped[float | None] = mapped_column(Float)  # s
    status: Mapped[str] = mapped_column(String(10))  # ok or error
    error_message: Mapped[str | None] = mapped_column(Text)
    recording: Mapped[str | None] = mapped_column(Text)  # path of its Rerun recording (.rrd), if written
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=_now)
    scene: Mapped[Scene] = relationship()
    excitation: Mapped[Excitation | None] = relationship()
    summary: Mapped["RunSummary | None"] = relationship(back_populates="run", cascade="all, delete-orphan")
    series: Mapped["RunSeries | None"] = relationship(back_populates="run", cascade="all, delete-orphan")
    blocks: Mapped[list["RunBlock"]] = relationship(back_populates="run", cascade="all, delete-orphan",
                                                    order_by="RunBlock.block")


class RunSummary(Base):
    """Key results of a run."""

    __tablename__ = "run_summaries"
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), primary_key=True)
    peak1_over_alpha: Mapped[float | None] = mapped_column(Float)  # max |theta1| / alpha1
    peak2_over_alpha: Mapped[float | None] = mapped_column(Float)  # max |theta2| / alpha2 (two blocks)
    overturned: Mapped[bool] = mapped_column(Boolean)
    overturned_blocks: Mapped[str | None] = mapped_column(String(10))  # "1", "2", "1,2"
    overturn_time: Mapped[float | None] = mapped_column(Float)  # s
    impacts: Mapped[int | None] = mapped_column(Integer)  # None: the closed form does not count them
    impacts_ground: Mapped[int | None] = mapped_column(Integer)
    impacts_interface: Mapped[int | None] = mapped_column(Integer)
    rest_time: Mapped[float | None] = mapped_column(Float)  # s
    # the rigid-rocking assumptions (docs/contact.md); None where the method does not monitor them
    assumptions_held: Mapped[bool | None] = mapped_column(Boolean)  # no contact slid or lifted off
    slide_time: Mapped[float | None] = mapped_column(Float)  # s, first sliding (None: none)
    lift_time: Mapped[float | None] = mapped_column(Float)  # s, first lift-off (None: none)
    friction_demand_max: Mapped[float | None] = mapped_column(Float)  # largest |T| / N on the ground
    normal_min: Mapped[float | None] = mapped_column(Float)  # smallest N of the ground / weight carried
    friction_demand_max_interface: Mapped[float | None] = mapped_column(Float)  # two blocks
    normal_min_interface: Mapped[float | None] = mapped_column(Float)  # two blocks: over block 2's weight
    impulse_demand_max: Mapped[float | None] = mapped_column(Float)  # largest |Pt| / Pn of an impact
    fall_time: Mapped[float | None] = mapped_column(Float)  # s, start of the overturning fall (None: none)
    # rocking–sliding runs (contact.model = 1, runners.engine.motion); None for rigid rocking
    motion: Mapped[str | None] = mapped_column(String(12))  # rests, slides, rocks, slide-rocks, overturns
    max_abs_slip: Mapped[float | None] = mapped_column(Float)  # m, peak |block1.slip|
    residual_slip: Mapped[float | None] = mapped_column(Float)  # m, block1.slip at the end (+x)
    slide_duration: Mapped[float | None] = mapped_column(Float)  # s, time spent sliding
    # rocking–sliding stacks: block 2 on block 1 (slips along block 1's top, relative to it); the
    # columns above are block 1's on the ground. None for one block and for rigid rocking
    block2_motion: Mapped[str | None] = mapped_column(String(12))  # as motion, or falls-off
    block2_max_abs_slip: Mapped[float | None] = mapped_column(Float)  # m, peak |block2.slip|
    block2_residual_slip: Mapped[float | None] = mapped_column(Float)  # m, block2.slip at the end (+x)
    block2_slide_duration: Mapped[float | None] = mapped_column(Float)  # s, time block 2 spent sliding
    block2_slide_time: Mapped[float | None] = mapped_column(Float)  # s, block 2's first slide (None: never)
    block2_fell_off: Mapped[bool | None] = mapped_column(Boolean)  # block 2 left block 1's top
    block2_fell_off_time: Mapped[float | None] = mapped_column(Float)  # s (None: it never fell off)
    # columns (nBlocks 3 to 8; each block's outcome: run_blocks); None for one block and two
    collapsed: Mapped[bool | None] = mapped_column(Boolean)  # a block overturned or fell off
    lowest_fallen: Mapped[int | None] = mapped_column(Integer)  # the lowest block that did (None: none)
    max_residual_slip: Mapped[float | None] = mapped_column(Float)  # m, largest |residual slip| of a standing block
    max_residual_slip_block: Mapped[int | None] = mapped_column(Integer)  # the block it is of
    run: Mapped[Run] = relationship(back_populates="summary")


class RunBlock(Base):
    """One block's outcome in a run of a column (nBlocks 3 to 8; revision 0014): slips relative to
    what the block stands on (block 1's on the ground, block K's along the top of block K - 1), m, +x."""

    __tablename__ = "run_blocks"
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), primary_key=True)
    block: Mapped[int] = mapped_column(Integer, primary_key=True)  # 1 (on the ground) to nBlocks
    max_abs_theta: Mapped[float] = mapped_column(Float)  # rad, peak |theta| (absolute)
    peak_over_alpha: Mapped[float | None] = mapped_column(Float)  # over its own alpha; None once it fell
    max_abs_slip: Mapped[float | None] = mapped_column(Float)  # m, peak |slip| on what it stands on
    residual_slip: Mapped[float | None] = mapped_column(Float)  # m, slip at the end (+x): its residual dislocation
    overturned: Mapped[bool] = mapped_column(Boolean)  # it fell, or rode a block under it that fell
    fell_off: Mapped[bool] = mapped_column(Boolean)  # it left the top of the block below
    final_mode: Mapped[str | None] = mapped_column(String(12))  # rest, slide, rock, slide-rock, overturned, ...
    run: Mapped[Run] = relationship(back_populates="blocks")


class RunSeries(Base):
    """The sampled outputs of a run, compressed and lossless (db.series): one row per run."""

    __tablename__ = "run_series"
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), primary_key=True)
    names: Mapped[list] = mapped_column(JSON)  # output variable names, in column order
    n_samples: Mapped[int] = mapped_column(Integer)
    data: Mapped[bytes] = mapped_column(LargeBinary)  # zlib of float64 time + columns
    # the run's events: [{"kind", "t" (s), "values": {name: float}, "labels": {name: str}}, ...]
    events: Mapped[list | None] = mapped_column(JSON)
    run: Mapped[Run] = relationship(back_populates="series")


class Measurement(Base):
    """A measured series: a free-rocking peak table, a rotation history, a shaking-table
    record or a recorded ground motion. Stored in SI units and the sign convention of
    docs/conventions.md, whatever the file declared (kept in `units` and `sign`)."""

    __tablename__ = "measurements"
    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    # peaks, rotation, table-displacement, table-acceleration, ground-acceleration
    kind: Mapped[str] = mapped_column(String(30))
    block1_id: Mapped[int | None] = mapped_column(ForeignKey("blocks.id"))
    block2_id: Mapped[int | None] = mapped_column(ForeignKey("blocks.id"))
    excitation_id: Mapped[int | None] = mapped_column(ForeignKey("excitations.id"))
    source: Mapped[str | None] = mapped_column(Text)  # who measured it, where it was published
    instrument: Mapped[str | None] = mapped_column(String(200))
    sampling_rate: Mapped[float | None] = mapped_column(Float)  # Hz
    uncertainty_angle: Mapped[float | None] = mapped_column(Float)  # rad
    uncertainty_time: Mapped[float | None] = mapped_column(Float)  # s
    uncertainty_value: Mapped[float | None] = mapped_column(Float)  # m or m/s^2, for motions
    units: Mapped[dict] = mapped_column(JSON)  # as the file declared them, e.g. {"time": "s", "theta": "deg"}
    sign: Mapped[str] = mapped_column(String(40))  # as the file declared it
    file_name: Mapped[str | None] = mapped_column(Text)
    file_sha256: Mapped[str | None] = mapped_column(String(64))
    names: Mapped[list] = mapped_column(JSON)  # column names (db.series), after time
    n_samples: Mapped[int] = mapped_column(Integer)
    data: Mapped[bytes] = mapped_column(LargeBinary)  # db.series: time then columns, SI, our signs
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=_now)
    block1: Mapped[Block | None] = relationship(foreign_keys=[block1_id])
    block2: Mapped[Block | None] = relationship(foreign_keys=[block2_id])
    excitation: Mapped[Excitation | None] = relationship()


class CosimRun(Base):
    """One co-simulation of blocks on a floor of a shear building (runners cosim,
    runners.engine.cosim_store): the system that ran (its file's text, the building, the blocks'
    floor, the blocks' and the building's parameters as run, the base record and its scale), the
    engine, the coupling and the communication step, and the run's summary."""

    __tablename__ = "cosim_runs"
    __table_args__ = {"sqlite_autoincrement": True}  # ids never reused after a delete, as sweeps' (revision 0013)
    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200))  # the system's name
    source: Mapped[str | None] = mapped_column(Text)  # the system file's text
    source_sha256: Mapped[str | None] = mapped_column(String(64))  # of that text (UTF-8)
    source_file: Mapped[str | None] = mapped_column(Text)  # where it was read from
    engine: Mapped[str] = mapped_column(String(20))  # fmpy, libcosim
    coupling: Mapped[str] = mapped_column(String(10))  # one-way, two-way
    step: Mapped[float] = mapped_column(Float)  # s, the communication step
    stop_time: Mapped[float] = mapped_column(Float)  # s, the last communication point
    storeys: Mapped[int] = mapped_column(Integer)
    floor: Mapped[int] = mapped_column(Integer)  # the floor the blocks stand on (1 = first above the base)
    # the system (runners.engine.cosim_store.system_dict): building (kg, N/m, damping ratio), blocks,
    # floor, coupling, step and stop time (s), the base record's file, scale and start time (s)
    system: Mapped[dict] = mapped_column(JSON)
    block_parameters: Mapped[dict] = mapped_column(JSON)  # the blocks' FMU parameters as run
    building_parameters: Mapped[dict] = mapped_column(JSON)  # the building's, two-way: the blocks' mass on their floor
    record_id: Mapped[int | None] = mapped_column(ForeignKey("records.id"), index=True)  # the base's stored record
    base_scale: Mapped[float] = mapped_column(Float)  # multiplier of the base record's accelerations
    base_sha256: Mapped[str | None] = mapped_column(String(64))  # of the record file the building's FMU read
    summary: Mapped[dict | None] = mapped_column(JSON)  # peaks, verdicts, energy balance (runners.analysis.cosim.summary)
    block_fmu_sha256: Mapped[str | None] = mapped_column(String(64))
    building_fmu_sha256: Mapped[str | None] = mapped_column(String(64))
    code_version: Mapped[str] = mapped_column(String(40))
    wall_time: Mapped[float | None] = mapped_column(Float)  # s
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=_now)
    record: Mapped[Record | None] = relationship()
    series: Mapped["CosimSeries | None"] = relationship(back_populates="run", cascade="all, delete-orphan")


class CosimSeries(Base):
    """Every output of a co-simulated run at every communication point, compressed and lossless
    (db.series, as run_series): one row per run."""

    __tablename__ = "cosim_series"
    run_id: Mapped[int] = mapped_column(ForeignKey("cosim_runs.id"), primary_key=True)
    names: Mapped[list] = mapped_column(JSON)  # "building.<variable>", "block.<variable>", in column order
    n_samples: Mapped[int] = mapped_column(Integer)
    data: Mapped[bytes] = mapped_column(LargeBinary)  # zlib of float64 time + columns
    run: Mapped[CosimRun] = relationship(back_populates="series")
