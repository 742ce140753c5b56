"""What the outputs depend on at the same instant (modelDescription's ModelStructure).

Knowns are the inputs ``ground.ah``, ``ground.av`` and ``support.force`` (which moves a two-way support's floor
at once, so it enters wherever the ground's horizontal acceleration does) and, in Model Exchange,
the continuous states ``block1.theta`` and ``block1.omega``. An output not
listed here depends on none of them (a discrete output, or one whose value
at a time does not change when an input changes at that time). The test
tests/test_fmu_structure.py checks every entry by perturbation.
"""

from __future__ import annotations

# Model Exchange: continuous state -> the variable that is its derivative
STATES: dict[str, str] = {
    "block1.theta": "block1.omega",
    "block1.omega": "block1.alpha_dd",
}

DEPENDENCIES: dict[str, tuple[str, ...]] = {
    "block1.theta": ("block1.theta",),
    "block1.omega": ("block1.omega",),
    "block1.alpha_dd": ("block1.theta", "block1.omega", "ground.ah", "support.force", "ground.av"),
    "block1.maxAbsTheta": ("block1.theta",),
    "energy": ("block1.theta", "block1.omega"),
    "ground.ahTotal": ("ground.ah", "support.force"),
    "ground.avTotal": ("ground.av",),
    "block2.alpha_dd": ("ground.ah", "support.force", "ground.av"),
    # Newton's law with the accelerations: the state and the ground's acceleration
    "contact.groundT": ("block1.theta", "block1.omega", "ground.ah", "support.force", "ground.av"),
    "contact.groundN": ("block1.theta", "block1.omega", "ground.ah", "support.force", "ground.av"),
    "contact.interfaceT": ("ground.ah", "support.force", "ground.av"),
    "contact.interfaceN": ("ground.ah", "support.force", "ground.av"),
    # the monitors' extremes include the reactions at the output time
    "friction.demandMaxGround": ("block1.theta", "block1.omega", "ground.ah", "support.force", "ground.av"),
    "contact.normalMinGround": ("block1.theta", "block1.omega", "ground.ah", "support.force", "ground.av"),
    "friction.demandMaxInterface": ("ground.ah", "support.force", "ground.av"),
    "contact.normalMinInterface": ("ground.ah", "support.force", "ground.av"),
}
