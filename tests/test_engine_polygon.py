"""The contact engine's polygonal bodies (engine_body_polygon), built as a white-box check with EN_MAX_BODIES = 8:
rectangles built as polygons against engine_body_rectangle at 8,000 random states and modes of columns of 1 to 8
bodies (derivatives, forces, indicators, the complementarity choice, impacts, projections); columns of 1 to 3
off-centre polygons rocking on a corner each, sticking, against Newton-Euler with the constraints written in the
check from the polygons directly; an off-centre body at rest just below and above its uplift acceleration to each
side; the plastic impact of one landing on its other corner (angular momentum about it); the overturn angles, the
uniform polygon's centroid and inertia; and the refusals of bodies that could not stand. tests/c/engine_polygon.c."""
import shutil
import subprocess

import pytest

from tests.conftest import compile_white_box

COLUMN = ("-DEN_MAX_BODIES=8", "-DNMAX=96", "-DLCP_MAX=48")


def _run(exe, *args):
    out = subprocess.run([str(exe), *args], capture_output=True, text=True, check=True).stdout.splitlines()
    refusals = {}
    for line in out[:-1]:
        _, name, status, *reason = line.split(" ")
        refusals[name] = (int(status), " ".join(reason))
    return [float(v) for v in out[-1].split()], refusals


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_polygonal_bodies(tmp_path):
    exe = compile_white_box(tmp_path, "engine_polygon.c", "lcp.c",
                            flags=("-O2", "-Wall", "-Wextra", "-Werror", *COLUMN))
    v, refusals = _run(exe)
    given, uniform, differ, evaluations = v[0], v[1], int(v[2]), int(v[3])
    dynamics, placement, wrong_lift, lifts = v[4], v[5], int(v[6]), int(v[7])
    momentum, not_open, hits, geometry, wrong_refusal, checks = v[8], int(v[9]), int(v[10]), v[11], int(v[12]), int(v[13])
    # a rectangle as a polygon: with its centre and inertia given the very same numbers; uniform (its inertia
    # within an ulp) the same to rounding, and the same modes, kinds, choices and impacts everywhere
    assert evaluations >= 70000 and differ == 0, (differ, evaluations)
    assert given == 0.0, given
    assert uniform <= 1e-12, uniform
    # off-centre columns against Newton-Euler from the polygons: accelerations over g (g / R), forces over the
    # weight carried; the corners placed at their anchors on the support's top (over R)
    assert 0.0 < dynamics <= 1e-12, dynamics
    assert placement <= 1e-14, placement
    # uplift to each side at 0.999 and 1.001 of g (xR - xG) / yG and g (xG - xL) / yG
    assert lifts == 12 and wrong_lift == 0, (wrong_lift, lifts)
    # landing on the other corner: angular momentum about it kept, the corner left opens
    assert hits == 6 and not_open == 0 and momentum <= 1e-12, (momentum, not_open, hits)
    assert geometry <= 1e-14, geometry
    assert wrong_refusal == 0 and checks == 28, (wrong_refusal, checks)
    expected = {"two_vertices": "at least 3 vertices", "not_finite": "not finite", "infinite": "not finite",
                "not_convex": "not convex", "bow_tie": "no area", "pentagram": "crosses itself",
                "no_area": "no area", "base_not_at_zero": "base must lie at y = 0",
                "pointed_base": "base is not flat", "tilted_base": "base is not flat", "mass_zero": "mass",
                "mass_negative": "mass", "IG_zero": "inertia", "IG_nan": "inertia",
                "uniform_IG_given_centre": "uniform inertia", "centre_beyond_right_corner": "between the base corners",
                "centre_on_left_corner_line": "between the base corners", "centre_on_base": "above the base",
                "centre_outside": "outside the polygon", "centre_not_finite": "not finite", "too_many": "at most 64",
                "stack_on_triangle": "no flat top"}
    for name, words in expected.items():
        status, reason = refusals[name]
        assert status != 0 and words in reason, (name, status, reason)
    for name in ("clockwise_rectangle", "collinear_and_repeated", "triangle_no_top"):
        assert refusals[name] == (0, ""), (name, refusals[name])


@pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("valgrind") is None,
                    reason="gcc or valgrind is not installed (Debian: valgrind)")
def test_polygonal_bodies_read_no_uninitialised_memory(tmp_path):
    """valgrind's memcheck over 400 states and every refusal: nothing read before it is set, nothing leaked."""
    exe = compile_white_box(tmp_path, "engine_polygon.c", "lcp.c", flags=("-O1", "-g", *COLUMN))
    p = subprocess.run(["valgrind", "--error-exitcode=9", "--track-origins=yes", "--leak-check=full", str(exe), "400"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "ERROR SUMMARY: 0 errors" in p.stderr
