"""A mesh of one's own (``Case.mesh_sizes``, ``--mesh-sizes``): sizes that replace the fitted
preset's, for the meshes of a convergence study. Without them the mesh, its keys and the files are
today's; with them the mesh is the preset's with exactly those sizes changed, and every key and
file name that depends on the mesh changes with it. Bad input is refused in one line before any
work."""

import json
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from fsistab.bodies import Plate
from fsistab.cli import app
from fsistab.errors import InputError
from fsistab.mesh import build_mesh, mesh_spec, mesh_statistics, preset_sizes, spec_for
from fsistab.params import MESH_SIZE_NAMES, Case, Domain, Flow, default_domain, parse_mesh_sizes
from fsistab.resources import estimate

runner = CliRunner()


def _case(**kwargs) -> Case:
    return Case(Plate(), Flow(2900.0), "coarse", **kwargs)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("bogus=1", "unknown mesh size 'bogus'"),
        ("near=0", "mesh size near must be positive"),
        ("near=-0.1", "mesh size near must be positive"),
        ("near=nan", "near"),
        ("near", "NAME=VALUE"),
        ("near=0.02,near=0.03", "given once"),
        ("wake=abc", "wake"),
    ],
)
def test_bad_sizes_are_refused_with_the_reason(text, message):
    with pytest.raises(InputError, match=message):
        Case.create("plate", 2900, preset="coarse", mesh_sizes=text)


def test_the_api_checks_its_pairs_too():
    with pytest.raises(InputError, match="mesh size wake must be a number"):
        _case(mesh_sizes=(("wake", "x"),))
    with pytest.raises(InputError, match="unknown mesh size 'Wake'"):
        _case(mesh_sizes=(("Wake", 0.1),))
    assert _case(mesh_sizes=(("wake", "0.2"),)).mesh_sizes == (("wake", 0.2),)


def test_no_sizes_is_todays_mesh_keys_and_names():
    for text in (None, "", "  "):
        case = Case.create("plate", 2900, preset="coarse", mesh_sizes=text)
        assert case.mesh_sizes == ()
        assert spec_for(case) == mesh_spec(Plate(), "coarse", 2900.0)
        assert case.tag == "plate_Re2900_a0" and case.mesh_tag == ""


def test_sizes_replace_the_fitted_presets_and_nothing_else():
    fitted = preset_sizes(Plate(), "coarse", 5800.0)
    case = Case.create(
        "plate", 2900, preset="coarse", mesh_reynolds=5800, mesh_sizes="wake_length=8, near=0.025,wake=0.1"
    )
    assert case.mesh_sizes == (("near", 0.025), ("wake", 0.1), ("wake_length", 8.0))
    sizes = spec_for(case).sizes
    assert (sizes.near, sizes.wake, sizes.wake_length) == (0.025, 0.1, 8.0)
    assert sizes == replace(fitted, near=0.025, wake=0.1, wake_length=8.0)
    # the fitted values differ, so the override is not the preset by accident
    assert (fitted.near, fitted.wake, fitted.wake_length) != (0.025, 0.1, 8.0)


def test_another_mesh_has_other_keys_and_file_names_whatever_the_order():
    plain = _case()
    ours = _case(mesh_sizes=(("wake", 0.1), ("near", 0.025)))
    assert ours == _case(mesh_sizes=(("near", 0.025), ("wake", 0.1)))
    assert spec_for(ours).key() != spec_for(plain).key()
    assert spec_for(ours).linear_identity() != spec_for(plain).linear_identity()
    assert ours.tag == "plate_Re2900_a0_sizes-near0.025-wake0.1"
    held = _case(mesh_reynolds=5800.0, mesh_sizes=(("near", 0.025),))
    assert held.tag == "plate_Re2900_a0_meshRe5800_sizes-near0.025"


def test_another_domain_has_other_file_names_and_the_presets_own_none():
    assert _case(domain=default_domain(Plate(), "coarse")).tag == "plate_Re2900_a0"
    assert _case(domain=Domain(40.0, 80.0, 40.0)).tag == "plate_Re2900_a0_domain40-80-40"
    both = _case(domain=Domain(40.0, 80.0, 40.0), mesh_reynolds=5800.0, mesh_sizes=(("near", 0.025),))
    assert both.tag == "plate_Re2900_a0_meshRe5800_domain40-80-40_sizes-near0.025"


def test_every_name_is_a_size_of_the_mesh():
    base = preset_sizes(Plate(), "medium", 2900.0)
    region = {"band": "middle_band"}  # the band's size is the middle size unless given
    for name in MESH_SIZE_NAMES:
        assert getattr(base, region.get(name, name)) is not None
        assert parse_mesh_sizes(f"{name}=2") == ((name, 2.0),)


def test_the_middle_size_needs_a_preset_with_a_middle_box():
    with pytest.raises(InputError, match="middle"):
        spec_for(_case(mesh_sizes=(("middle", 2.0),)))


def test_the_band_size_needs_a_preset_with_a_band_and_keeps_todays_keys_without_one():
    with pytest.raises(InputError, match="no middle band"):
        spec_for(_case(mesh_sizes=(("band", 1.0),)))
    medium = Case.create("plate", 2900, preset="medium")
    assert "band" not in spec_for(medium).sizes.key_inputs()
    banded = Case.create("plate", 2900, preset="medium", mesh_sizes="middle=2,band=1")
    sizes = spec_for(banded).sizes
    assert (sizes.middle, sizes.band) == (2.0, 1.0)
    coarser = Case.create("plate", 2900, preset="medium", mesh_sizes="middle=2")
    assert spec_for(banded).key() != spec_for(coarser).key()


def test_a_band_of_its_own_size_meshes_the_band_finer_than_the_box(tmp_path):
    # a small domain with a middle box and band (1-body-length elements), so that it meshes quickly
    small = {"domain": Domain(8.0, 16.0, 8.0), "sponge": None, "far": 2.0, "middle": 1.0}
    small |= {"middle_box": (6.0, 14.0, 6.0), "middle_band": (16.0, 2.0), "wake_length": 3.0}
    plain = mesh_spec(Plate(), "coarse", 2900.0, **small)
    banded = mesh_spec(Plate(), "coarse", 2900.0, **small, band=0.4)
    plain_mesh, banded_mesh = (build_mesh(spec, tmp_path) for spec in (plain, banded))
    # inside the band, away from the wake box and the box's edges: 0.4 instead of 1
    inside = {"x": (5.0, 13.0), "y": (1.0, 1.8)}
    plain_edge, banded_edge = (_median_edge(mesh, **inside) for mesh in (plain_mesh, banded_mesh))
    assert 0.7 < plain_edge < 1.3 and 0.7 < banded_edge / 0.4 < 1.3, (plain_edge, banded_edge)
    # the size estimate knows the band's size (docs/performance.md: within a factor 1.25)
    for spec, mesh in ((plain, plain_mesh), (banded, banded_mesh)):
        assert 0.8 < estimate(spec).unknowns / mesh_statistics(mesh)["ndof"] < 1.25


def _median_edge(mesh, x: tuple[float, float], y: tuple[float, float]) -> float:
    """The median edge length of the triangles whose centroid lies in ``x × ±y``."""
    from ngsolve import VOL

    points = np.array([mesh[v].point for v in mesh.vertices])
    triangles = np.array([[v.nr for v in element.vertices] for element in mesh.Elements(VOL)])
    corners = points[triangles]
    centre = corners.mean(axis=1)
    across = np.abs(centre[:, 1])
    chosen = (centre[:, 0] > x[0]) & (centre[:, 0] < x[1]) & (across > y[0]) & (across < y[1])
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)[chosen]
    return float(np.median(edges))


def test_the_command_builds_the_mesh_with_the_sizes(tmp_path):
    cache, out = str(tmp_path / "cache"), str(tmp_path / "out")
    common = ["mesh", "--mesh", "coarse", "--json", "--cache", cache, "--out", out]
    plain = json.loads(runner.invoke(app, common).stdout)
    coarser = json.loads(runner.invoke(app, [*common, "--mesh-sizes", "wake=0.3"]).stdout)
    # a coarser wake box: fewer elements, another mesh, another figure
    assert coarser["triangles"] < plain["triangles"] and coarser["ndof"] < plain["ndof"]
    assert coarser["mesh_key"] != plain["mesh_key"]
    assert coarser["figure"].endswith("_sizes-wake0.3.png") and coarser["figure"] != plain["figure"]


def test_the_command_refuses_a_bad_size_in_one_line(tmp_path):
    result = runner.invoke(app, ["critical", "--mesh", "coarse", "--mesh-sizes", "nearr=0.02"])
    assert result.exit_code == 2
    assert result.output.strip().splitlines() == [
        "error: unknown mesh size 'nearr': choose among " + ", ".join(MESH_SIZE_NAMES)
    ]
