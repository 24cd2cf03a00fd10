"""Sections given by an outline (docs/model.md §11): NACA four-digit sections and curves read from
a file — their checks before any mesh, their splined faces and curved meshes, and a plate read from
points against the built-in plate."""

import logging
import math

import numpy as np
import pytest

from fsistab.bodies import Airfoil, Curve, body_type, make_body
from fsistab.errors import InputError
from fsistab.forces import aerodynamic_coefficients
from fsistab.linalg import FactorCounter
from fsistab.mesh import build_mesh, mesh_spec
from fsistab.operators import fluid_operators
from fsistab.outlines import naca_digits, naca_outline, read_points
from fsistab.params import Case, Flow
from fsistab.slopes import static_slopes
from fsistab.steady import solve_steady

# the closed-trailing-edge NACA 00tt area, 10 t ∫₀¹ (0.2969√x - 0.1260x - 0.3516x² + 0.2843x³ - 0.1036x⁴) dx
NACA_AREA_PER_THICKNESS = 10 * (0.2969 * 2 / 3 - 0.1260 / 2 - 0.3516 / 3 + 0.2843 / 4 - 0.1036 / 5)


def plate_points(aspect_ratio=20.0, corner_radius=0.1, side=21, short=5, arc=9):
    """The built-in plate's outline (rounded rectangle, chord 1) as points, counter-clockwise from
    the lower long side: straight sides with inner points, corner arcs sampled."""
    e = 1 / aspect_ratio
    r = corner_radius * e
    points = []

    def line(p, q, n):
        points.extend(np.array(p) + (np.array(q) - np.array(p)) * t for t in np.linspace(0, 1, n)[:-1])

    def arc_from(centre, angle):
        points.extend(
            np.array(centre) + r * np.array([math.cos(a), math.sin(a)])
            for a in np.linspace(angle, angle + math.pi / 2, arc)[:-1]
        )

    h = e / 2
    line((-0.5 + r, -h), (0.5 - r, -h), side)
    arc_from((0.5 - r, -h + r), -math.pi / 2)
    line((0.5, -h + r), (0.5, h - r), short)
    arc_from((0.5 - r, h - r), 0.0)
    line((0.5 - r, h), (-0.5 + r, h), side)
    arc_from((-0.5 + r, h - r), math.pi / 2)
    line((-0.5, h - r), (-0.5, -h + r), short)
    arc_from((-0.5 + r, -h + r), math.pi)
    return np.array(points)


def write_points(path, points, header="x,y"):
    path.write_text("\n".join([header, *(f"{x!r},{y!r}" for x, y in points.tolist())]) + "\n")
    return path


@pytest.mark.parametrize(
    ("name", "expected"),
    [("naca0012", (0.0, 0.0, 0.12)), ("naca2412", (0.02, 0.4, 0.12)), ("naca4415", (0.04, 0.4, 0.15))],
)
def test_naca_names(name, expected):
    assert naca_digits(name) == pytest.approx(expected)
    assert body_type(name) is Airfoil


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("naca0000", "thickness"),
        ("naca0050", "thickness"),
        ("naca2012", "no camber position"),
        ("naca0412", "no camber"),
        ("naca23012", "four digits"),
        ("nacaXX12", "four digits"),
    ],
)
def test_naca_names_out_of_range_are_refused(name, message):
    with pytest.raises(InputError, match=message):
        make_body(name)


def test_naca_thickness_and_trailing_edges():
    closed = naca_outline("naca0012", "closed")
    assert closed[0] == pytest.approx([0.5, 0.0], abs=1e-15)  # the two surfaces meet at the rear
    thickness = 2 * closed[:, 1].max()
    assert thickness == pytest.approx(0.12, abs=2e-4)  # 12 % thick
    assert closed[np.argmax(closed[:, 1]), 0] == pytest.approx(-0.2, abs=0.01)  # at 30 % chord
    open_ = naca_outline("naca0012", "open")
    # the original coefficients leave a blunt trailing edge 2·5t·0.0021 = 0.00252 thick
    assert math.dist(open_[0], open_[-1]) == pytest.approx(0.00252, rel=1e-3)
    cambered = naca_outline("naca2412")
    upper, lower = cambered[: len(cambered) // 2 + 1][::-1], cambered[len(cambered) // 2 :]
    # the mean of the two surfaces at 40 % chord is the camber line's peak, 2 % of the chord
    peak = np.argmin(np.abs(upper[:, 0] + 0.1))
    assert (upper[peak, 1] + lower[peak, 1]) / 2 == pytest.approx(0.02, abs=2e-4)


def test_splined_faces_enclose_the_exact_areas(tmp_path):
    naca = Airfoil().face(0.03, 0.005)
    assert naca.mass == pytest.approx(0.12 * NACA_AREA_PER_THICKNESS, rel=2e-5)
    plate = Curve.read(write_points(tmp_path / "plate.csv", plate_points()))
    exact = 0.05 - (4 - math.pi) * 0.005**2  # the rounded rectangle: its sides and arcs recognised
    assert plate.face(0.03, 0.005).mass == pytest.approx(exact, rel=1e-12)
    assert [edge.mass for edge in plate.face(0.03, 0.005).edges] == pytest.approx(
        [0.04, math.pi * 0.005 / 2, 0.99, math.pi * 0.005 / 2] * 2, rel=1e-12
    )
    assert plate.symmetric and Airfoil().symmetric and not Airfoil("naca2412").symmetric


def test_points_file_is_read_checked_and_normalised(tmp_path, caplog):
    t = np.linspace(0, 2 * math.pi, 40, endpoint=False)
    circle = np.column_stack([3 + 2 * np.cos(t), 1 + 2 * np.sin(t)])  # diameter 4, off the origin
    path = tmp_path / "circle.txt"
    path.write_text("# a circle\nX Y\n\n" + "\n".join(f"{x} {y}" for x, y in circle[::-1]) + "\n")
    with caplog.at_level(logging.WARNING, logger="fsistab"):
        curve = Curve.read(path)  # clockwise in the file: reversed, and the log says so
    assert "clockwise" in caplog.text
    outline = curve.outline
    assert np.ptp(outline[:, 0]) == pytest.approx(1.0)  # unit chord
    assert outline[:, 0].min() == pytest.approx(-0.5) and outline[0, 0] == pytest.approx(0.5)
    polygon = 0.5 * np.sum(
        outline[:, 0] * np.roll(outline[:, 1], -1) - np.roll(outline[:, 0], -1) * outline[:, 1]
    )
    assert polygon == pytest.approx(0.5 * 40 * 0.25 * math.sin(2 * math.pi / 40))  # counter-clockwise
    scaled = Curve.read(path, reference_length=2.0)  # lengths in units of 2: chord 2
    assert np.ptp(scaled.outline[:, 0]) == pytest.approx(2.0)
    assert read_points(write_points(tmp_path / "c.csv", circle, header="x;y")).shape == (40, 2)


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ("0,0\n1,0\n1,1\n", "at least 12"),
        ("\n".join(f"{x},{x * x}" for x in np.linspace(-1, 1, 20)), "not closed"),
        ("x,y\n0,0\n1,a\n", "line 3"),
        ("0,0,0\n", "two finite numbers"),
    ],
)
def test_bad_points_files_are_refused_in_one_line(tmp_path, rows, message):
    path = tmp_path / "bad.csv"
    path.write_text(rows)
    with pytest.raises(InputError, match=message) as info:
        Curve.read(path)
    assert "\n" not in str(info.value)


def test_a_self_intersecting_curve_is_refused(tmp_path):
    t = np.linspace(0, 2 * math.pi, 30, endpoint=False)
    figure_eight = np.column_stack([np.sin(t), np.sin(t) * np.cos(t)])
    with pytest.raises(InputError, match="intersects itself"):
        Curve.read(write_points(tmp_path / "eight.csv", figure_eight))


@pytest.mark.parametrize("name", ["naca0012", "naca2412"])
def test_curved_meshes_enclose_the_splined_body(name):
    """The mirrored half (symmetric section, tabulated projection) and the whole mesh (cambered
    section, netgen's curving on the geometry) both carry the splined wall: the fluid's area is the
    domain's minus the face's, to the projection's accuracy."""
    from ngsolve import Integrate

    body = make_body(name)
    spec = mesh_spec(body, "coarse", 1000)
    mesh = build_mesh(spec)
    d = spec.domain
    solid = (d.upstream + d.downstream) * 2 * d.lateral - Integrate(1, mesh)
    assert solid == pytest.approx(body.face(1.0, 1.0).mass, rel=1e-5)


def test_every_command_refuses_a_bad_body_before_any_work(tmp_path):
    from typer.testing import CliRunner

    from fsistab.cli import app

    open_curve = write_points(tmp_path / "open.csv", np.column_stack([np.linspace(0, 1, 20), np.zeros(20)]))
    cache = tmp_path / "cache"
    for args, message in [
        (["steady", "--body", "naca0050"], "thickness"),
        (["spectrum", "--body-file", str(open_curve)], "not closed"),
        (["critical", "--body", "naca2012"], "camber position"),
        (["steady", "--body", "naca0012", "--body-file", str(open_curve)], "not both"),
    ]:
        result = CliRunner().invoke(app, [*args, "--mesh", "coarse", "--Re", "100", "--cache", str(cache)])
        assert result.exit_code == 2, result.output
        assert message in result.output and result.output.count("\n") <= 2
    assert not (cache / "meshes").exists()


@pytest.mark.parametrize("kind", ["naca0012", "curve"])
def test_cases_from_command_line_options(tmp_path, kind):
    path = write_points(tmp_path / "plate.csv", plate_points())
    case = Case.create(kind, 1000, 2.0, "coarse", body_file=str(path) if kind == "curve" else None)
    assert case.kind == kind and case.tag == f"{kind}_Re1000_a2"


def test_a_plate_read_from_points_reproduces_the_built_in_plate(tmp_path, plate_2900, plate_operators):
    """The plate's outline as points (its sides and corner arcs recognised as lines and arcs) gives
    the built-in plate's drag and static slopes within 0.5 % on the coarse mesh at Re 2900 (the
    built-in plate's steady state and operators are the session's)."""
    curve = Curve.read(write_points(tmp_path / "plate.csv", plate_points()))
    steady = solve_steady(mesh_spec(curve, "coarse", 2900), Flow(2900, 0.0))
    results = []
    for flow, operators in ((plate_2900, plate_operators), (steady, fluid_operators(steady))):
        slopes = static_slopes(operators, FactorCounter())
        results.append((aerodynamic_coefficients(flow).drag, slopes.lift, slopes.moment))
    for built_in, read in zip(*results, strict=True):
        assert read == pytest.approx(built_in, rel=5e-3)


def test_a_cambered_section_lifts_at_zero_incidence(tmp_path):
    """NACA 2412 (meshed whole, curved on its geometry) through the command line: positive camber
    lifts at α0 = 0 and pitches nose-down (C_M > 0, counter-clockwise +), where a symmetric section
    has neither."""
    import json

    from typer.testing import CliRunner

    from fsistab.cli import app

    args = ["steady", "--body", "naca2412", "--Re", "40", "--mesh", "coarse", "--json"]
    result = CliRunner().invoke(app, [*args, "--out", str(tmp_path), "--cache", str(tmp_path / "cache")])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["body"] == "naca2412"
    assert payload["lift_coefficient"] > 0.01 and payload["moment_coefficient"] > 0.001


def test_shape_options_are_checked_for_every_body(tmp_path):
    with pytest.raises(InputError, match="closed or open"):
        make_body("naca0012", trailing_edge="blunt")
    with pytest.raises(InputError, match="closed or open"):
        make_body("plate", trailing_edge="blunt")  # refused although the plate does not use it
    with pytest.raises(InputError, match="--body-file"):
        make_body("plate", reference_length=2.0)
    with pytest.raises(InputError, match="--body-file"):
        make_body("curve")
    path = write_points(tmp_path / "plate.csv", plate_points())
    with pytest.raises(InputError, match="reference length"):
        make_body("curve", body_file=str(path), reference_length=-1.0)
