"""A mesh of one's own (``Case.mesh_sizes``, ``--mesh-sizes``): sizes that replace the fitted
preset's, for the meshes of a convergence study. Without them the mesh, its keys and the files are
today's; with them the mesh is the preset's with exactly those sizes changed, and every key and
file name that depends on the mesh changes with it. Bad input is refused in one line before any
work."""

import json
from dataclasses import replace

import pytest
from typer.testing import CliRunner

from fsistab.bodies import Plate
from fsistab.cli import app
from fsistab.errors import InputError
from fsistab.mesh import mesh_spec, preset_sizes, spec_for
from fsistab.params import MESH_SIZE_NAMES, Case, Flow, parse_mesh_sizes

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
        assert case.tag == "plate_Re2900_a0" and case.sizes_tag == ""


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


def test_every_name_is_a_size_of_the_mesh():
    base = preset_sizes(Plate(), "medium", 2900.0)
    for name in MESH_SIZE_NAMES:
        assert getattr(base, name) is not None
        assert parse_mesh_sizes(f"{name}=2") == ((name, 2.0),)


def test_the_middle_size_needs_a_preset_with_a_middle_box():
    with pytest.raises(InputError, match="middle"):
        spec_for(_case(mesh_sizes=(("middle", 2.0),)))


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
