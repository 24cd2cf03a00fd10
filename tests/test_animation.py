"""The vorticity animation of a time march (fsistab.animation, docs/model.md §4, §12): the vorticity
of fields whose curl is known, and `fsistab simulate --animation` end to end on the coarse cylinder
mesh (a GIF with one frame per snapshot of the steps marched in the run)."""

import json
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from typer.testing import CliRunner

from fsistab import animation, cli
from fsistab.animation import ContinuousVorticity, Frame, colour_limit, frame_title, vorticity, vorticity_grid
from fsistab.bodies import Cylinder
from fsistab.mesh import build_mesh, mesh_spec
from fsistab.steady import taylor_hood_space

runner = CliRunner()


@pytest.fixture(scope="module")
def cylinder_space(cache_dir):
    """The coarse cylinder mesh, its Taylor–Hood space and a vorticity grid of its mode window."""
    mesh = build_mesh(mesh_spec(Cylinder(), "coarse", 60), cache_dir)
    grid = vorticity_grid(mesh, animation.animation_window(Cylinder()), nx=120)
    return taylor_hood_space(mesh), grid


def _vorticity_of(space, grid, field) -> tuple[np.ndarray, np.ndarray]:
    """ω of ``field`` on ``grid``: of the P2 velocity, and projected onto continuous P1 (the frames')."""
    from ngsolve import CF, GridFunction

    state = GridFunction(space)
    state.components[0].Set(CF(field))
    projected = ContinuousVorticity(space.mesh, state.components[0]).update()
    return grid.sample(vorticity(state.components[0])), grid.sample(projected)


def test_vorticity_of_known_fields(cylinder_space):
    """P2 holds these fields exactly (but in the curved elements at the wall, to 1e-2), and the
    projection of their vorticity onto P1 too: a solid-body rotation has ω = 2, a uniform flow 0,
    the shear (0, X) has ω = +1 (∂V/∂X alone: the sign of the curl) and (Y², 0) has ω = −2Y."""
    from ngsolve import x, y

    space, grid = cylinder_space
    fluid = grid.inside
    assert fluid.sum() > 0.95 * fluid.size and not fluid.all()  # the body is cut out of the window
    gx, gy = np.meshgrid(grid.x, grid.y)
    assert np.all(gx[~fluid] ** 2 + gy[~fluid] ** 2 < 0.5**2 + 1e-2)  # only the disc of diameter 1
    for name, field, expected in [
        ("rotation (-Y, X)", (-y, x), 2.0 + 0 * gx),
        ("uniform (1, 0.3)", (1.0, 0.3), 0 * gx),
        ("shear (0, X)", (0, x), 1.0 + 0 * gx),
        ("shear (Y², 0)", (y * y, 0), -2 * gy),
    ]:
        for omega in _vorticity_of(space, grid, field):
            assert np.isnan(omega[~fluid]).all()
            error = np.abs(omega[fluid] - expected[fluid])
            assert error.max() < 1e-2 and np.quantile(error, 0.95) < 1e-5, (name, error.max())


def test_colour_limit_and_title():
    frames = [Frame(i, 0.1 * i, np.full((4, 4), value, dtype=np.float32)) for i, value in enumerate((-3, 1))]
    frames[0].vorticity[0, 0] = np.nan
    assert colour_limit(frames, 1.0) == 3.0 and colour_limit(frames, 0.0) == 1.0
    assert colour_limit([Frame(0, 0.0, np.zeros((2, 2), dtype=np.float32))]) == 1.0
    title = frame_title("cylinder, Re = 60", 1.25, 0.01, np.radians(-2.0))
    assert title == "cylinder, Re = 60: t = 1.25, h = +0.0100, θ = -2.000°"
    assert frame_title("plate", 0.0, -0.0, -1e-9).endswith("h = +0.0000, θ = +0.000°")


def _simulate(tmp_path, cache, duration: str):
    args = ["simulate", "--body", "cylinder", "--Re", "60", "--mesh", "coarse", "--dofs", "none"]
    args += ["--perturbation", "0", "--time-step", "0.1", "--snapshot-interval", "0.1", "--animation", "gif"]
    args += ["--duration", duration, "--json", "--out", str(tmp_path / "out"), "--cache", str(cache)]
    result = runner.invoke(cli.app, args)
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def _frames(path) -> int:
    from PIL import Image

    with Image.open(path) as image:
        assert image.format == "GIF" and image.size[0] >= 600
        return image.n_frames


def test_simulate_animates_the_steps_marched_in_the_run(tmp_path, cache_dir):
    """Three steps of Δt = 0.1 with a snapshot every 0.1: a GIF of three frames beside three VTK
    files; resumed to t = 0.5, the two steps marched; rerun with nothing to march, no animation."""
    first = _simulate(tmp_path, cache_dir / "animation", "0.3")
    path = tmp_path / "out" / "simulate_cylinder_Re60_a0_vorticity.gif"
    assert first["animation"] == str(path) and first["animation_frames"] == 3 and len(first["vtk"]) == 3
    assert _frames(path) == 3
    resumed = _simulate(tmp_path, cache_dir / "animation", "0.5")
    assert resumed["steps_this_run"] == 2 and resumed["animation_frames"] == 2
    assert _frames(path) == 2
    again = _simulate(tmp_path, cache_dir / "animation", "0.5")
    assert again["steps_this_run"] == 0 and again["animation"] is None and again["animation_frames"] == 0


@pytest.mark.parametrize(
    "extra, reason",
    [
        (["--animation", "gif"], "--animation needs --snapshot-interval"),
        (["--animation", "webm", "--snapshot-interval", "0.1"], "--animation must be one of gif, mp4"),
        (["--animation", "mp4", "--snapshot-interval", "0.1"], "needs ffmpeg"),
    ],
)
def test_animation_refused_before_any_work(extra, reason, tmp_path):
    """Without a snapshot interval, in an unknown format, or MP4 without ffmpeg: one line, exit 2,
    before the march (nothing written)."""
    args = ["simulate", "--body", "cylinder", "--mesh", "coarse", "--duration", "1", *extra, "--json"]
    args += ["--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")]
    with mock.patch.object(animation, "_ffmpeg_available", lambda: False):
        result = runner.invoke(cli.app, args)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1 and reason in lines[0], result.output
    assert result.stdout == "" and list(Path(tmp_path).iterdir()) == []
