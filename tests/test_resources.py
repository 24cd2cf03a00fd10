"""Estimated mesh size and memory (fsistab.resources) against real meshes: issue #13, item 4."""

import math
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsistab import bodies, resources
from fsistab.bodies import Cylinder, Plate
from fsistab.errors import InputError
from fsistab.mesh import build_mesh, mesh_spec, mesh_statistics
from fsistab.params import Domain
from fsistab.resources import Estimate, check_fits, estimate

FACTOR = 1.25  # the accuracy stated in the module docstring

# coarse meshes only (each builds in about a second): both bodies, the Re-fitted wall sizes, and
# a smaller and a larger domain than the defaults
MESHES = {
    "plate Re 2900": (Plate(), 2900.0, None),
    "plate Re 100": (Plate(), 100.0, None),
    "plate Re 2900, domain 10, 20, 10": (Plate(), 2900.0, Domain(10, 20, 10)),
    "plate Re 2900, domain 40, 80, 40": (Plate(), 2900.0, Domain(40, 80, 40)),
    "cylinder Re 40": (Cylinder(), 40.0, None),
    "cylinder Re 40, domain 25, 50, 25": (Cylinder(), 40.0, Domain(25, 50, 25)),
}


@pytest.fixture(scope="session")
def measured_meshes(cache_dir):
    """``mesh_statistics`` of every mesh of MESHES, built once per session."""
    measured = {}
    for name, (body, reynolds, domain) in MESHES.items():
        spec = mesh_spec(body, "coarse", reynolds, domain)
        measured[name] = (spec, mesh_statistics(build_mesh(spec, cache_dir)))
    return measured


@pytest.mark.parametrize("name", list(MESHES))
def test_estimate_is_within_the_stated_factor_of_the_real_mesh(measured_meshes, name):
    spec, measured = measured_meshes[name]
    found = estimate(spec)
    assert 1 / FACTOR < found.unknowns / measured["ndof"] < FACTOR
    assert 1 / FACTOR < found.triangles / measured["triangles"] < FACTOR


def test_estimate_counts_the_middle_box_and_band(cache_dir):
    """A graded far field with a band behind the body (the converged presets' layout, scaled down):
    the estimate stays within the stated factor, and the band adds what it adds to the real mesh."""
    sizes = {"far": 4.0, "middle": 1.0, "middle_box": (10, 20, 10)}
    domain = Domain(20, 60, 20)
    plain = mesh_spec(Plate(), "coarse", 2900.0, domain, **sizes)
    banded = mesh_spec(Plate(), "coarse", 2900.0, domain, **sizes, middle_band=(60, 5))
    counts = [mesh_statistics(build_mesh(spec, cache_dir))["ndof"] for spec in (plain, banded)]
    found = [estimate(spec).unknowns for spec in (plain, banded)]
    assert all(1 / FACTOR < f / c < FACTOR for f, c in zip(found, counts, strict=True))
    assert 0.5 < (found[1] - found[0]) / (counts[1] - counts[0]) < 2


def test_estimate_counts_the_far_wake(cache_dir):
    """A far-wake box (the wake's finer elements continued downstream): the estimate adds what the
    real mesh adds, within a factor 2."""
    sizes = {"far": 4.0, "middle": 1.0, "middle_box": (10, 20, 10), "middle_band": (60, 5)}
    domain = Domain(20, 60, 20)
    plain = mesh_spec(Plate(), "coarse", 2900.0, domain, **sizes)
    graded = mesh_spec(Plate(), "coarse", 2900.0, domain, **sizes, far_wake=(0.3, 60, 1.5))
    counts = [mesh_statistics(build_mesh(spec, cache_dir))["ndof"] for spec in (plain, graded)]
    found = [estimate(spec).unknowns for spec in (plain, graded)]
    assert counts[1] > counts[0] + 5000
    assert 0.5 < (found[1] - found[0]) / (counts[1] - counts[0]) < 2


@pytest.mark.parametrize("name", list(MESHES))
def test_taylor_hood_unknowns_follow_from_euler_formula(measured_meshes, name):
    """The estimator's ``ndof = 4.5 T + 2.5 B``: with ``V - E + T = 0`` (one hole) and
    ``3T + B = 2E``, ``3V + 2E = 5V + 2T``, checked on NGSolve's own count."""
    _, measured = measured_meshes[name]
    assert measured["ndof"] == 5 * measured["vertices"] + 2 * measured["triangles"]


def test_disc_area_in_rectangles_is_exact():
    """The cylinder's area in a quadtree cell (inclusion-exclusion of quadrant areas)."""
    corner = bodies.disc_corner_area
    r = 0.5

    def in_rectangle(x0, x1, y0, y1):
        return float(corner(x1, y1, r) - corner(x0, y1, r) - corner(x1, y0, r) + corner(x0, y0, r))

    assert in_rectangle(-1, 1, -1, 1) == pytest.approx(math.pi / 4, rel=1e-14)
    assert in_rectangle(-1, 1, 0, 1) == pytest.approx(math.pi / 8, rel=1e-14)
    assert in_rectangle(0, 0.5, 0, 0.5) == pytest.approx(math.pi / 16, rel=1e-14)
    # a band |x| ≤ 0.3: twice the segment beyond, subtracted from the disc
    segment = r * r * math.acos(0.3 / r) - 0.3 * math.sqrt(r * r - 0.09)
    assert in_rectangle(-0.3, 0.3, -1, 1) == pytest.approx(math.pi / 4 - 2 * segment, rel=1e-14)
    assert in_rectangle(0.6, 1, -1, 1) == 0.0


reynolds_numbers = st.floats(min_value=1.0, max_value=3e4, allow_nan=False)
extents = st.tuples(
    st.floats(min_value=2.0, max_value=80.0), st.floats(min_value=2.0, max_value=160.0), st.floats(2.0, 80.0)
)


@settings(max_examples=30, deadline=None)
@given(body=st.sampled_from([Plate(), Cylinder()]), pair=st.tuples(reynolds_numbers, reynolds_numbers))
def test_estimate_grows_with_the_reynolds_number(body, pair):
    low, high = sorted(pair)
    smaller, larger = estimate(mesh_spec(body, "coarse", low)), estimate(mesh_spec(body, "coarse", high))
    assert smaller.triangles <= larger.triangles
    assert smaller.unknowns <= larger.unknowns
    assert smaller.memory_bytes <= larger.memory_bytes


@settings(max_examples=30, deadline=None)
@given(body=st.sampled_from([Plate(), Cylinder()]), first=extents, second=extents)
def test_estimate_grows_with_the_domain(body, first, second):
    small = Domain(*(min(a, b) for a, b in zip(first, second, strict=True)))
    large = Domain(*(max(a, b) for a, b in zip(first, second, strict=True)))
    smaller = estimate(mesh_spec(body, "coarse", 1000.0, small))
    larger = estimate(mesh_spec(body, "coarse", 1000.0, large))
    assert smaller.unknowns <= larger.unknowns
    assert smaller.memory_bytes <= larger.memory_bytes


def test_check_fits_refuses_reynolds_1e6_on_the_medium_plate_at_once():
    spec = mesh_spec(Plate(), "medium", 1e6)
    with pytest.raises(InputError) as error:
        check_fits(spec, memory_available=10**15)  # refused by the size limit, whatever the memory
    message = str(error.value)
    assert "\n" not in message
    assert "unknowns" in message and "GB" in message and "--mesh" in message and "--Re" in message
    with pytest.raises(InputError):
        check_fits(spec)  # and with the default, this machine's memory


@pytest.mark.parametrize(
    "spec",
    [
        mesh_spec(Plate(), "coarse", 1e6),
        mesh_spec(Cylinder(), "medium", 1e6),
        mesh_spec(Plate(), "coarse", 100.0, far=1e-3),
    ],
    ids=["plate coarse Re 1e6", "cylinder medium Re 1e6", "far size 0.001"],
)
def test_absurd_meshes_are_refused_from_a_lower_bound(spec):
    found = estimate(spec)
    assert found.lower_bound and found.unknowns > resources.MAX_UNKNOWNS
    with pytest.raises(InputError, match="^mesh too large: at least"):
        check_fits(spec, memory_available=10**15)


def test_check_fits_refuses_beyond_the_memory_available():
    spec = mesh_spec(Plate(), "medium", 2900.0)  # about 417 000 unknowns
    with pytest.raises(InputError, match=r"0\.5 GB available") as error:
        check_fits(spec, memory_available=500_000_000)
    assert "\n" not in str(error.value)


def test_check_fits_accepts_the_coarse_preset(measured_meshes):
    spec, measured = measured_meshes["plate Re 2900"]
    found = check_fits(spec)
    assert isinstance(found, Estimate) and not found.lower_bound
    assert found.memory_bytes < 1e9  # a coarse steady solve and complex LU peaked at 0.37 GB
    assert found.unknowns > measured["ndof"] / FACTOR


def test_describe_gives_unknowns_triangles_and_memory():
    text = Estimate(triangles=24_941, unknowns=113_055, memory_bytes=1_556_661_434).describe()
    assert text == "about 113 055 unknowns (24 941 triangles), peak memory about 1.6 GB"
    assert Estimate(1, 2, 3, lower_bound=True).describe().startswith("at least 2 unknowns")


def test_physical_memory_matches_proc_meminfo():
    meminfo = Path("/proc/meminfo")
    if not meminfo.exists():
        pytest.skip("no /proc/meminfo")
    total = next(line for line in meminfo.read_text().splitlines() if line.startswith("MemTotal:"))
    kib = int(total.split()[1])
    assert resources.physical_memory() == pytest.approx(kib * 1024, rel=0.05)


_MEASURE_PEAK = """
import resource, sys
from fsistab.linalg import FluidFactor
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow
from fsistab.bodies import Plate
from fsistab.steady import solve_steady

steady = solve_steady(mesh_spec(Plate(), "coarse", 100.0), Flow(100.0))
FluidFactor(fluid_operators(steady), 0.05 + 0.2j)
print(steady.state.space.ndof, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)
"""


@pytest.mark.slow
def test_memory_estimate_against_a_measured_steady_solve_and_complex_lu():
    """Peak resident memory of a fresh process: coarse plate mesh, steady Newton, one complex LU."""
    done = subprocess.run(
        [sys.executable, "-c", _MEASURE_PEAK], capture_output=True, text=True, check=True, timeout=600
    )
    unknowns, peak = (int(word) for word in done.stdout.split()[-2:])
    assert 1 / FACTOR < resources.memory_bytes(unknowns) / peak < FACTOR
