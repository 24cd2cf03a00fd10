"""Figures: one function per figure, each taking computed objects and a path (matplotlib, Agg)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.tri as mtri  # noqa: E402
import numpy as np  # noqa: E402


def _triangulation(mesh) -> mtri.Triangulation:
    coords = mesh.ngmesh.Coordinates()
    nodes = mesh.ngmesh.Elements2D().NumPy()["nodes"][:, :3].astype(np.int64) - 1
    return mtri.Triangulation(coords[:, 0], coords[:, 1], nodes)


def _save(fig, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.part{path.suffix}")
    fig.savefig(tmp, dpi=150, bbox_inches="tight")
    plt.close(fig)
    tmp.replace(path)
    return path


def plot_mesh(mesh, path: Path, title: str = "") -> Path:
    """The whole mesh and a close-up of the body."""
    tri = _triangulation(mesh)
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.5))
    for ax, (xlim, ylim) in zip(axes, [(None, None), ((-0.8, 1.6), (-0.6, 0.6))], strict=True):
        ax.triplot(tri, lw=0.2, color="k")
        ax.set_aspect("equal")
        if xlim:
            ax.set_xlim(*xlim)
            ax.set_ylim(*ylim)
        ax.set_xlabel("X")
        ax.set_ylabel("Y")
    axes[0].set_title(title or f"{mesh.ne} triangles")
    axes[1].set_title("close-up")
    return _save(fig, path)


def plot_streamwise_velocity(steady, path: Path, window=None) -> Path:
    """Relative streamwise velocity ``(U - W⁰)·d`` near the body, recirculation outlined (= 0)."""
    from fsistab.forces import streamwise_direction
    from fsistab.steady import wall_velocity

    mesh = steady.mesh
    tri = _triangulation(mesh)
    values = np.asarray(steady.velocity(mesh(tri.x, tri.y)))
    d = streamwise_direction(steady.flow.theta0)
    relative = (values - np.array(wall_velocity(steady.flow.theta0))) @ d
    if window is None:
        window = ((-1.0, 3.0), (-0.8, 0.8)) if steady.mesh_spec.body.kind == "plate" else ((-2, 6), (-2, 2))
    fig, ax = plt.subplots(figsize=(10, 4))
    levels = np.linspace(min(relative.min(), -0.2), max(relative.max(), 1.2), 41)
    cs = ax.tricontourf(tri, relative, levels=levels, cmap="RdBu_r")
    ax.tricontour(tri, relative, levels=[0.0], colors="k", linewidths=1.2)
    fig.colorbar(cs, ax=ax, label="streamwise velocity (body frame)")
    ax.set_xlim(*window[0])
    ax.set_ylim(*window[1])
    ax.set_aspect("equal")
    ax.set_xlabel("X")
    ax.set_ylabel("Y")
    ax.set_title(
        f"{steady.mesh_spec.body.kind}, Re = {steady.flow.reynolds:g}, "
        f"alpha0 = {steady.flow.alpha0_deg:g} deg (black: zero streamwise velocity)"
    )
    return _save(fig, path)


_LABEL_COLOURS = {"fluid": "tab:blue", "heave": "tab:red", "pitch": "tab:green", "coupled": "tab:purple"}


def plot_spectrum(ds, path: Path, title: str = "") -> Path:
    """Eigenvalues in the (growth rate, frequency) plane, and a close-up near the neutral axis."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    growth, frequency, labels = ds["growth_rate"].values, ds["frequency"].values, ds["label"].values
    for ax in axes:
        for label, colour in _LABEL_COLOURS.items():
            sel = labels == label
            if sel.any():
                ax.plot(growth[sel], frequency[sel], "o", color=colour, label=label, ms=6)
        ax.axvline(0, color="k", lw=0.8)
        ax.set_xlabel("growth rate λ")
        ax.set_ylabel("frequency ω")
        ax.grid(alpha=0.3)
    axes[0].legend()
    axes[0].set_title(title or "spectrum")
    near = np.abs(growth) <= max(0.05, 2 * np.abs(growth).min()) if growth.size else growth
    span = max(np.abs(growth[near]).max() if np.any(near) else 0.05, 1e-3) * 1.3
    axes[1].set_xlim(-span, span)
    axes[1].set_title("close-up near the neutral axis")
    return _save(fig, path)


def write_modes_vtk(steady, fluid_index, modes: dict[str, np.ndarray], path: Path) -> Path:
    """Real and imaginary parts of the velocity and pressure of each mode, as one VTK file.

    ``modes`` maps a name to a fluid vector (the fluid unknowns, indexed by ``fluid_index``).
    """
    from ngsolve import GridFunction, VTKOutput

    coefs, names = [], []
    for name, vector in modes.items():
        for part, values in (("re", vector.real), ("im", vector.imag)):
            field = GridFunction(steady.space)
            field.vec.FV().NumPy()[fluid_index] = values
            coefs += [field.components[0], field.components[1]]
            names += [f"{name}_velocity_{part}", f"{name}_pressure_{part}"]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    VTKOutput(steady.mesh, coefs=coefs, names=names, filename=str(path.with_suffix("")), subdivision=1).Do()
    return path.with_suffix(".vtu")
