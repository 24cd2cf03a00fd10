"""Animations of a time march (docs/model.md §12): the vorticity near the body, one frame per
snapshot of :func:`fsistab.workflows.simulate`, written with :mod:`matplotlib.animation`.

The march's velocity unknown is the **absolute** velocity written in the body axes,
``U = R(θ)ᵀu`` (docs/model.md §4), on a mesh that never moves in the body frame. The scalar
vorticity ``ω_z = ∂V/∂X − ∂U/∂Y`` of ``U`` is that of ``u`` in the laboratory at the same material
point (a rotation of the axes leaves it unchanged): the frames show the physical vorticity, the
body fixed, the wake moving past it. The velocity relative to the moving body, ``U − W``, would
have ``ω_z − 2θ'`` (the frame's rotation ``θ'(−Y, X)``; the translation ``R(θ)ᵀ(−1, h')`` is
uniform and adds none).

The vorticity of the P2 velocity is discontinuous between elements (the coarse wake's triangles
would show as facets): it is projected onto continuous P1 (NGSolve's ``Set``, averaged at shared
vertices; exact for a vorticity linear in space, and smoother to the eye than a P2 projection,
whose local oscillations show as a texture) and sampled on a regular grid of the body's mode
window (:class:`VorticityGrid`, the NGSolve point search done once). A frame is one small float32
array (one velocity and one vorticity GridFunction are reused, none is kept per frame), and the
colour scale, symmetric and the same for every frame, is chosen once all frames are known. The
recorder (:class:`VorticityRecorder`) only sees the snapshots of the steps marched in its run: a
march resumed from its checkpoint animates the time it adds.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from fsistab.errors import InputError

ANIMATION_FORMATS = ("gif", "mp4")
GRID_POINTS = 400  # grid points along X (the window's width); Y in proportion
COLOUR_QUANTILE = 0.99  # of |ω| over every frame: the colour limit (the wall's peaks saturate)
FRAMES_PER_SECOND = 10


# --- the option, checked before any work -------------------------------------------------------------


def check_animation(fmt: str, snapshot_interval: float | None) -> str:
    """``fmt`` if an animation in that format can be made of a march with this snapshot interval,
    else InputError (one line): ``gif`` (Pillow) or ``mp4`` (ffmpeg on the PATH, as matplotlib finds
    it), and a snapshot interval (the simulated time between frames)."""
    if fmt not in ANIMATION_FORMATS:
        raise InputError(f"--animation must be one of {', '.join(ANIMATION_FORMATS)}, not {fmt!r}")
    if snapshot_interval is None:
        raise InputError("--animation needs --snapshot-interval (the simulated time between frames)")
    if fmt == "mp4" and not _ffmpeg_available():
        raise InputError("--animation mp4 needs ffmpeg, which matplotlib does not find (or use gif)")
    return fmt


def _ffmpeg_available() -> bool:
    from matplotlib.animation import FFMpegWriter

    return bool(FFMpegWriter.isAvailable())


def animation_path(out: Path, tag: str, fmt: str) -> Path:
    """Where the vorticity animation of the march ``tag`` goes: ``simulate_{tag}_vorticity.{fmt}``."""
    return Path(out) / f"simulate_{tag}_vorticity.{fmt}"


# --- the vorticity on a regular grid -----------------------------------------------------------------


def vorticity(velocity):
    """The CoefficientFunction ``ω_z = ∂V/∂X − ∂U/∂Y`` of a velocity field (docs/model.md §4:
    ``grad`` of a vector field has rows ``∇U``, ``∇V``)."""
    from ngsolve import grad

    gradient = grad(velocity)
    return gradient[1, 0] - gradient[0, 1]


def animation_window(body):
    """The window of the frames: the body's mode window (the wake's structures), moved with the frame
    of a section pitching about an elastic axis (:func:`fsistab.bodies.frame_offset`)."""
    from fsistab.bodies import frame_offset

    (x0, x1), (y0, y1) = body.mode_window
    offset = frame_offset(body)
    return (x0 + offset, x1 + offset), (y0, y1)


class VorticityGrid(NamedTuple):
    """A regular grid over ``window`` on a mesh: cell centres ``x`` (``nx``) and ``y`` (``ny``),
    ``inside`` (``(ny, nx)``) flags those in the fluid, ``points`` are their NGSolve MeshPoints
    (found once, so that a field is evaluated without a point search), ``outline`` is the body's
    wall as closed polygons (:func:`fsistab.plots.sample_mesh`)."""

    window: tuple
    x: np.ndarray
    y: np.ndarray
    inside: np.ndarray
    points: np.ndarray
    outline: tuple[np.ndarray, ...]

    def sample(self, cf) -> np.ndarray:
        """The scalar ``cf`` on the grid, ``(ny, nx)`` float32, NaN outside the fluid (in the body)."""
        values = np.full(self.inside.shape, np.nan, dtype=np.float32)
        values[self.inside] = np.asarray(cf(self.points), dtype=np.float32).reshape(-1)
        return values


def vorticity_grid(mesh, window, nx: int = GRID_POINTS) -> VorticityGrid:
    """:class:`VorticityGrid` of ``mesh`` over ``window = ((x0, x1), (y0, y1))`` with ``nx`` cells
    along ``X`` and square cells."""
    from fsistab.plots import sample_mesh

    (x0, x1), (y0, y1) = window
    ny = max(2, round(nx * (y1 - y0) / (x1 - x0)))
    x = x0 + (np.arange(nx) + 0.5) * (x1 - x0) / nx
    y = y0 + (np.arange(ny) + 0.5) * (y1 - y0) / ny
    gx, gy = np.meshgrid(x, y)
    found = mesh(gx.ravel(), gy.ravel())  # element -1 outside the mesh
    inside = (found["nr"] >= 0).reshape(gx.shape)
    outline = sample_mesh(mesh, 2, window).outline
    return VorticityGrid(window, x, y, inside, found[inside.ravel()], outline)


class Frame(NamedTuple):
    """One snapshot: its index (a multiple of the snapshot interval), simulated time and ``ω_z`` on
    the grid."""

    index: int
    time: float
    vorticity: np.ndarray


class ContinuousVorticity:
    """``ω_z`` of ``velocity`` (:func:`vorticity`) projected onto continuous P``order`` on ``mesh``
    by NGSolve's ``Set`` (local projections averaged at shared degrees of freedom): :meth:`update`
    recomputes it from the velocity's current values and returns the field."""

    def __init__(self, mesh, velocity, order: int = 1):
        from ngsolve import H1, GridFunction

        self.source = vorticity(velocity)
        self.field = GridFunction(H1(mesh, order=order))

    def update(self):
        self.field.Set(self.source)
        return self.field


class VorticityRecorder:
    """The snapshot callback of :func:`fsistab.workflows.simulate` that keeps ``ω_z`` of each state
    on a :class:`VorticityGrid` of ``window`` (the body's :func:`animation_window` when None) as a
    :class:`Frame` (a float32 array of about ``nx² / 2`` values; the grid, a velocity field and its
    :class:`ContinuousVorticity` are made at the first snapshot and reused). ``title`` names the
    case (body, Re, α0) once a state was seen."""

    def __init__(self, window=None, nx: int = GRID_POINTS):
        self.window, self.nx = window, nx
        self.frames: list[Frame] = []
        self.grid: VorticityGrid | None = None
        self.title = ""
        self._field = self._vorticity = None

    def __call__(self, index: int, time: float, steady, state: np.ndarray) -> None:
        if self.grid is None:
            from ngsolve import GridFunction

            window = self.window or animation_window(steady.mesh_spec.body)
            self.grid = vorticity_grid(steady.mesh, window, self.nx)
            self._field = GridFunction(steady.space)
            self._vorticity = ContinuousVorticity(steady.mesh, self._field.components[0])
            flow = steady.flow
            self.title = f"{steady.mesh_spec.body.kind}, Re = {flow.reynolds:g}, α0 = {flow.alpha0_deg:g}°"
        self._field.vec.FV().NumPy()[:] = state
        self.frames.append(Frame(int(index), float(time), self.grid.sample(self._vorticity.update())))


def chain(*callbacks: Callable | None) -> Callable:
    """One snapshot callback calling each of ``callbacks`` (None skipped) in turn."""
    active = [c for c in callbacks if c is not None]

    def call(*args) -> None:
        for callback in active:
            callback(*args)

    return call


# --- the animation -----------------------------------------------------------------------------------


def colour_limit(frames: Sequence[Frame], quantile: float = COLOUR_QUANTILE) -> float:
    """The symmetric colour limit shared by every frame: the ``quantile`` of ``|ω_z|`` over all
    frames' fluid points (the thin wall layers' peaks saturate; the wake stays resolved), 1 when the
    field vanishes."""
    values = np.abs(np.concatenate([f.vorticity[np.isfinite(f.vorticity)] for f in frames]))
    limit = float(np.quantile(values, quantile)) if values.size else 0.0
    return limit if limit > 0 else 1.0


def frame_title(case: str, time: float, heave: float, pitch: float) -> str:
    """The title of a frame: the case, the simulated time and the body's ``h`` (body lengths) and
    ``θ`` (degrees, counter-clockwise +) at that time (docs/model.md §3)."""
    h, theta = round(heave, 4) + 0.0, round(float(np.degrees(pitch)), 3) + 0.0  # no "-0.000"
    return f"{case}: t = {time:.2f}, h = {h:+.4f}, θ = {theta:+.3f}°"


def solid_at(ds, time: float) -> tuple[float, float]:
    """``(h, θ)`` of the march's time series ``ds`` (coordinate ``time``) at its step nearest ``time``."""
    step = ds.sel(time=time, method="nearest")
    return float(step["heave"]), float(step["pitch"])


def _gif_writer(fps: float):
    """A matplotlib movie writer of GIFs by Pillow (as ``PillowWriter``) whose frames are reduced to
    the first frame's palette of 256 colours as they come, without dithering: the smooth colour
    fields stay smooth (dithering speckles them and defeats GIF's compression) and a frame is held
    as one byte per pixel until the file is written."""
    from io import BytesIO

    from matplotlib.animation import AbstractMovieWriter
    from PIL import Image

    class GifWriter(AbstractMovieWriter):
        def setup(self, fig, outfile, dpi=None):
            super().setup(fig, outfile, dpi=dpi)
            self.images = []

        def grab_frame(self, **savefig_kwargs):
            buffer = BytesIO()
            self.fig.savefig(buffer, **{**savefig_kwargs, "format": "rgba", "dpi": self.dpi})
            rgb = Image.frombuffer("RGBA", self.frame_size, buffer.getbuffer(), "raw", "RGBA", 0, 1)
            rgb = rgb.convert("RGB")
            palette = {"palette": self.images[0]} if self.images else {"colors": 256}
            self.images.append(rgb.quantize(dither=Image.Dither.NONE, **palette))

        def finish(self):
            duration = int(1000 / self.fps)
            self.images[0].save(
                self.outfile, save_all=True, append_images=self.images[1:], duration=duration, loop=0
            )

    return GifWriter(fps=fps)


def _writer(fmt: str, fps: float):
    from matplotlib.animation import FFMpegWriter

    return _gif_writer(fps) if fmt == "gif" else FFMpegWriter(fps=fps)


def write_vorticity_animation(
    recorder: VorticityRecorder, ds, path: Path, fps: float = FRAMES_PER_SECOND, dpi: float = 100
) -> Path | None:
    """The frames of ``recorder`` as an animation at ``path`` (GIF or MP4 by its suffix), written
    atomically: ``ω_z`` in the body frame (a diverging colour map, symmetric, one scale for every
    frame: :func:`colour_limit`), the body filled, each frame titled with its time and ``h``, ``θ``
    read from the march's time series ``ds`` (:func:`frame_title`). None (nothing written) when
    there is no frame (no snapshot time in the steps marched this run)."""
    import matplotlib.pyplot as plt

    from fsistab.plots import draw_body, figure_style
    from fsistab.store import atomic_path

    frames, grid = recorder.frames, recorder.grid
    if not frames:
        return None
    path = Path(path)
    limit = colour_limit(frames)
    (x0, x1), (y0, y1) = grid.window
    with figure_style():
        fig, ax = plt.subplots(figsize=(8.0, 0.8 + 8.0 * 0.8 * (y1 - y0) / (x1 - x0)), layout="constrained")
        try:
            image = ax.imshow(
                frames[0].vorticity,
                extent=(x0, x1, y0, y1),
                origin="lower",
                cmap="RdBu_r",
                vmin=-limit,
                vmax=limit,
                interpolation="nearest",
            )
            fig.colorbar(image, ax=ax, label="vorticity ω_z", extend="both", shrink=0.9)
            draw_body(ax, grid.outline)
            ax.set_xlim(x0, x1)
            ax.set_ylim(y0, y1)
            ax.set_aspect("equal")
            ax.set_xlabel("X (body frame)")
            ax.set_ylabel("Y")
            title = ax.set_title("")
            writer = _writer(path.suffix.lstrip(".").lower(), fps)
            with atomic_path(path, path.suffix) as tmp, writer.saving(fig, str(tmp), dpi):
                for frame in frames:
                    image.set_data(frame.vorticity)
                    title.set_text(frame_title(recorder.title, frame.time, *solid_at(ds, frame.time)))
                    writer.grab_frame()
        finally:
            plt.close(fig)
    return path
