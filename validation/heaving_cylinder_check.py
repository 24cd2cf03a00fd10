"""Structure mode of the heaving cylinder (Navrose & Mittal 2016) by Arnoldi at given U*, and a figure.

Companion of ``validation/heaving_cylinder.py``. Beyond coincidence the structure mode sits among
weakly damped fluid modes of the wake (at Re = 60, m = 20: λ ≈ -0.05 to -0.065, spaced ≈ 0.03 in
ω), several of which carry half of the near-body energy in the solid; nearest-eigenvalue tracking
can then step onto one of them. Here shift-invert Arnoldi runs near ``iω_n √(m/(m+1))`` at each U*
(``--n-eigenvalues`` eigenvalues) and the structure mode is the eigenpair with the largest solid
share of the near-body kinetic energy. Writes ``OUT/data/heaving_cylinder_check.nc`` (every
eigenvalue found) and redraws the branches of ``OUT/data/heaving_cylinder.nc`` with these points
on top (``OUT/figures/heaving_cylinder.png``).

Usage: python validation/heaving_cylinder_check.py --velocities 9 10 11 12 [--preset medium]
"""

import argparse
import math
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from ngsolve import SetNumThreads  # noqa: E402

from fsistab.bodies import Cylinder
from fsistab.coupled import CoupledSystem  # noqa: E402
from fsistab.eigen import eigenpairs_near  # noqa: E402
from fsistab.mesh import mesh_spec  # noqa: E402
from fsistab.operators import fluid_operators  # noqa: E402
from fsistab.params import Flow, Solid  # noqa: E402
from fsistab.plots import save_figure  # noqa: E402
from fsistab.steady import solve_steady  # noqa: E402
from fsistab.store import default_cache_dir, json_attr, write_dataset  # noqa: E402


def figure(branches: xr.Dataset, check: xr.Dataset, path: Path, title: str) -> Path:
    """Tracked branches (lines) and the Arnoldi structure modes (squares); filled: unstable."""
    u = branches["reduced_velocity"].values
    m = float(branches.attrs["mass_ratio"])
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    colours = {"fluid": "tab:blue", "solid": "tab:orange"}
    for name in branches["branch"].values:
        g = branches["growth_rate"].sel(branch=name).values
        w = branches["frequency"].sel(branch=name).values
        c = colours.get(str(name), "k")
        for ax, y in zip(axes, (g, w), strict=True):
            ax.plot(u, y, "-", color=c, lw=1.2, label=f"{name} branch (tracked)")
            ax.plot(u[g <= 0], y[g <= 0], "o", mfc="white", mec=c, ms=5)
            ax.plot(u[g > 0], y[g > 0], "o", color=c, ms=5)
    uc = check["reduced_velocity"].values
    best = check["structure_mode"].values
    gc = check["growth_rate"].values[np.arange(len(uc)), best]
    wc = check["frequency"].values[np.arange(len(uc)), best]
    for ax, y in zip(axes, (gc, wc), strict=True):
        ax.plot(uc, y, "s", mfc="white", mec="tab:red", ms=7, label="structure mode (Arnoldi)")
    # the other eigenvalues found near iω_n√(m/(m+1)): wake modes sharing the solid energy
    for i in range(len(uc)):
        others = [j for j in range(check.sizes["candidate"]) if j != best[i]]
        label = "other eigenvalues near iω_n√(m/(m+1))" if i == 0 else None
        axes[1].plot(
            [uc[i]] * len(others), check["frequency"].values[i, others], ".", color="0.6", ms=4, label=label
        )
        axes[0].plot([uc[i]] * len(others), check["growth_rate"].values[i, others], ".", color="0.6", ms=4)
    fine = np.linspace(u.min(), u.max(), 200)
    axes[1].plot(
        fine, 2 * np.pi / fine * math.sqrt(m / (m + 1)), "--", color="0.3", lw=1, label="(2π/U*)√(m/(m+1))"
    )
    fixed = float(branches.attrs["fixed_cylinder_frequency"])
    axes[1].axhline(fixed, ls=":", color="0.3", lw=1, label=f"fixed cylinder ω = {fixed:.4f}")
    axes[0].axhline(0, color="k", lw=0.8)
    axes[0].set_ylabel("growth rate λ")
    axes[1].set_ylabel("frequency ω")
    for ax in axes:
        ax.set_xlabel("reduced velocity U*")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8)
    axes[0].set_title(title)
    fig.tight_layout()
    return save_figure(fig, path)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="medium")
    parser.add_argument("--reynolds", type=float, default=60.0)
    parser.add_argument("--mass-ratio", type=float, default=20.0)
    parser.add_argument("--velocities", type=float, nargs="+", default=[9.0, 10.0, 11.0, 12.0])
    parser.add_argument("--n-eigenvalues", type=int, default=6)
    parser.add_argument("--plot-only", action="store_true", help="redraw from the NetCDF files")
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=Path("docs"))
    args = parser.parse_args()
    check_path = args.out / "data" / "heaving_cylinder_check.nc"
    if not args.plot_only:
        SetNumThreads(2)
        m, reynolds = args.mass_ratio, args.reynolds
        spec = mesh_spec(Cylinder(), args.preset, reynolds)
        steady = solve_steady(spec, Flow(reynolds), cache_dir=args.cache or default_cache_dir())
        fluid = fluid_operators(steady)
        velocities = sorted(args.velocities)
        k = args.n_eigenvalues
        values = np.full((len(velocities), k), np.nan + 0j)
        share = np.full((len(velocities), k), np.nan)
        labels = np.full((len(velocities), k), "", dtype=object)
        seconds = []
        print(
            "| U* | ω_n√(m/(m+1)) | structure mode σ | solid share | ω/(ω_n√(m/(m+1))) "
            "| others (σ, share) | t [s] |"
        )
        print("|---|---|---|---|---|---|---|")
        for i, velocity in enumerate(velocities):
            t0 = time.perf_counter()
            target = 2 * math.pi / velocity * math.sqrt(m / (m + 1))
            system = CoupledSystem(fluid, Solid.cylinder(m, velocity))
            pairs = eigenpairs_near(system, [1j * target + (0.0013 + 0.0017j)], k)
            pairs = sorted(pairs, key=lambda p: p.frequency)[:k]
            for j, p in enumerate(pairs):
                values[i, j], share[i, j], labels[i, j] = p.value, p.solid_energy_fraction, p.label
            seconds.append(time.perf_counter() - t0)
            best = max(pairs, key=lambda p: p.solid_energy_fraction)
            others = "; ".join(
                f"{p.growth_rate:+.4f} + {p.frequency:.4f}i ({p.solid_energy_fraction:.2f})"
                for p in pairs
                if p is not best
            )
            print(
                f"| {velocity:g} | {target:.5f} | {best.growth_rate:+.5f} + {best.frequency:.5f}i | "
                f"{best.solid_energy_fraction:.3f} | {best.frequency / target:.4f} | {others} | "
                f"{seconds[-1]:.0f} |",
                flush=True,
            )
        ds = xr.Dataset(
            {
                "growth_rate": (("reduced_velocity", "candidate"), values.real),
                "frequency": (("reduced_velocity", "candidate"), values.imag),
                "solid_energy_fraction": (("reduced_velocity", "candidate"), share),
                "label": (("reduced_velocity", "candidate"), labels.astype(str)),
                "structure_mode": ("reduced_velocity", np.nanargmax(share, axis=1)),
                "seconds": ("reduced_velocity", np.array(seconds)),
            },
            coords={"reduced_velocity": velocities, "candidate": np.arange(k)},
            attrs={
                "case": "heaving cylinder (docs/validation.md): Arnoldi near i omega_n sqrt(m/(m+1))",
                "reynolds": reynolds,
                "mass_ratio": m,
                "mesh": json_attr(spec.describe()),
                "ndof": fluid.n_fluid + 2,
            },
        )
        write_dataset(ds, check_path)
    branches = xr.open_dataset(args.out / "data" / "heaving_cylinder.nc")
    check = xr.open_dataset(check_path)
    path = figure(
        branches,
        check,
        args.out / "figures" / "heaving_cylinder.png",
        f"heaving cylinder, Re = {branches.attrs['reynolds']:g}, m = {branches.attrs['mass_ratio']:g} "
        f"({args.preset} mesh; filled: unstable)",
    )
    print(f"data {check_path}, figure {path}")


if __name__ == "__main__":
    main()
