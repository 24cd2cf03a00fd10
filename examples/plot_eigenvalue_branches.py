"""Eigenvalue branches of the plate against U* (Re = 2900, m = 1000); its flutter, divergence, VIV modes.

Shows the growth rate and frequency of the heave, pitch and wake branches of the coupled system
(docs/model.md §7) followed along a sweep of U* in [2, 10] (``fsistab.critical.find_thresholds``: branch
tracking, each sign change refined by Newton on the augmented system of docs/model.md §8, divergence
from the static system), with the in-vacuo frequencies Ω/U* and 1/U* dashed and the thresholds
marked; then the same along U* in [0.06, 0.09], where the heave frequency Ω/U* meets the wake
mode's (VIV); then the pressure of the critical mode at the flutter onset, the divergence and the
VIV onset, with the body's displacement drawn (divergence: ω = 0, U*_D = √(m r_θ²/(dC_M/dθ))).

Command-line equivalent (thresholds only, no figure)::

    fsistab critical --body plate --Re 2900 --mass-ratio 1000 --wake-shift 11.2j --method tracking \\
        --mesh coarse

Mesh: ``--mesh`` preset (default coarse). Reference (Moulin & Marquet 2021): at m = 1000 flutter sets
in at U*_F ≈ 4.5 and static divergence at U*_D ≈ 7.4; the wake mode is slightly stable with
ω ≈ 11.2; for U* → 0 the solid branches tend to σ/ω_θ = 0.8i (heave) and -0.05 + 0.999i (pitch).

Usage: python examples/plot_eigenvalue_branches.py [--mesh coarse] [--out DIR] [--points 24]
"""

import argparse
from pathlib import Path

VIV_RANGE = (0.06, 0.09)  # U* of the VIV sweep at m = 1000 (around Ω/ω_wake ≈ 0.074)


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--mesh", default="coarse", choices=("coarse", "medium", "fine"), help="mesh preset")
    parser.add_argument(
        "--out", type=Path, default=Path("gallery-out"), help="directory for figures and data"
    )
    parser.add_argument("--cache", type=Path, default=None, help="cache (default $FSISTAB_CACHE)")
    parser.add_argument("--format", default="png", choices=("png", "pdf", "svg"), help="figure format")
    parser.add_argument("--points", type=int, default=24, help="values of U* in [2, 10] (log-spaced)")
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    import numpy as np

    from fsistab.critical import find_thresholds
    from fsistab.errors import ConvergenceError
    from fsistab.linalg import FactorCounter
    from fsistab.mesh import spec_for
    from fsistab.operators import fluid_operators
    from fsistab.params import Case, solid_for
    from fsistab.steady import solve_steady
    from fsistab.store import default_cache_dir

    case = Case.create("plate", 2900.0, 0.0, args.mesh)
    steady = solve_steady(spec_for(case), case.flow, cache_dir=args.cache or default_cache_dir())
    fluid = fluid_operators(steady)
    velocities = np.geomspace(2.0, 10.0, args.points)
    solid = solid_for("plate", mass_ratio=1000.0, reduced_velocity=velocities[0])
    counter = FactorCounter()
    # branch tracking (not the default frequency sweep): the branches themselves are drawn
    thresholds, details = find_thresholds(
        fluid, solid, velocities, wake_shift=11.2j, counter=counter, method="tracking"
    )
    branches = details["branches"]

    for t in thresholds:
        print(f"{t.kind:10s} {t.boundary:15s} U* = {t.reduced_velocity:.5f}, ω = {t.frequency:.5f}")
    for (
        name,
        branch,
    ) in branches.items():  # σ/ω_θ = σU* (Moulin & Marquet 2021: 0.8i heave, -0.05 + 0.999i pitch)
        sigma = branch.values[0] * branch.parameters[0]
        print(f"{name} branch at U* = {branch.parameters[0]:g}: σU* = {sigma.real:+.4f} + {sigma.imag:.4f}i")
    title = f"plate, Re = 2900, m = 1000, {args.mesh} mesh"
    figures = [draw(branches, thresholds, args.out / f"branches_{case.tag}_m1000.png", title)]

    # VIV: the heave frequency Ω/U* meets the wake mode's (ω ≈ 10.8) near U* = Ω/ω ≈ 0.074
    viv_velocities = np.geomspace(*VIV_RANGE, 16)
    viv_solid = solid_for("plate", mass_ratio=1000.0, reduced_velocity=viv_velocities[0])
    wake = 1j * branches["wake"].values[0].imag
    try:
        viv, viv_details = find_thresholds(
            fluid, viv_solid, viv_velocities, wake_shift=wake, counter=counter, method="tracking"
        )
        viv_branches = viv_details["branches"]
    except ConvergenceError as exc:  # reported, and the rest is still drawn
        print(f"VIV sweep: {exc}")
        viv = []
    for t in viv:
        print(f"{t.kind:10s} {t.boundary:15s} U* = {t.reduced_velocity:.6f}, ω = {t.frequency:.5f}")
    if viv:
        path = args.out / f"branches_viv_{case.tag}_m1000.png"
        figures.append(draw(viv_branches, viv, path, f"{title}: where Ω/U* meets the wake mode"))
    print(f"{counter.count} factorisations")

    # the critical modes: flutter and divergence onsets of the first sweep, the first VIV onset
    # (an onset and a restabilisation at one point are a growth rate touching zero: not an onset)
    touching = {
        (a.branch, round(a.reduced_velocity, 8))
        for a in thresholds + viv
        for b in thresholds + viv
        if a.branch == b.branch
        and a.boundary != b.boundary
        and abs(a.reduced_velocity - b.reduced_velocity) < 1e-9
    }
    onsets = [
        t
        for t in thresholds + viv
        if t.boundary == "onset" and (t.branch, round(t.reduced_velocity, 8)) not in touching
    ]
    chosen = {t.kind: t for t in reversed(onsets)}
    for kind, threshold in chosen.items():
        path = args.out / f"{kind}_mode_{case.tag}_m1000.png"
        figures.append(critical_mode_figure(steady, fluid, solid, threshold, path))
    print("figures:", ", ".join(str(f) for f in figures))


def critical_mode_figure(steady, fluid, solid, threshold, path: Path) -> Path:
    """Pressure of a threshold's critical mode (σ = iω_c) with the body's displacement drawn."""
    from dataclasses import replace

    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import neutral_eigenpair
    from fsistab.plots import plot_mode_snapshot

    system = CoupledSystem(fluid, replace(solid, reduced_velocity=threshold.reduced_velocity))
    pair = neutral_eigenpair(system, threshold.frequency, threshold.mode)
    return plot_mode_snapshot(steady, fluid.free_dofs, pair, system, path)


def draw(branches: dict, thresholds: list, path: Path, title: str) -> Path:
    """Growth rates of every branch; frequencies of the solid branches (in-vacuo dashed) and of
    the wake branch; filled markers where a branch is unstable; thresholds as vertical lines."""
    import matplotlib.pyplot as plt
    import numpy as np

    from fsistab.plots import figure_style, save_figure

    colours = {"heave": "tab:red", "pitch": "tab:green", "wake": "tab:blue"}
    with figure_style():
        fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
        for name, branch in branches.items():
            u, sigma = np.array(branch.parameters), np.array(branch.values)
            unstable = sigma.real > 0
            colour = colours.get(name, "k")
            for ax, y in ((axes[0], sigma.real), (axes[2 if name == "wake" else 1], sigma.imag)):
                ax.plot(u, y, "-", color=colour, lw=1.2, label=f"{name} branch")
                ax.plot(u[~unstable], y[~unstable], "o", mfc="white", mec=colour, ms=4)
                ax.plot(u[unstable], y[unstable], "o", color=colour, ms=4)
        u = np.geomspace(
            min(b.parameters[0] for b in branches.values()), max(b.parameters[-1] for b in branches.values())
        )
        axes[1].plot(u, 0.8 / u, "--", color="0.4", lw=1, label="heave in vacuo Ω/U*")
        axes[1].plot(u, 1.0 / u, ":", color="0.4", lw=1, label="pitch in vacuo 1/U*")
        axes[0].axhline(0, color="k", lw=0.8)
        axes[0].set_yscale("symlog", linthresh=1e-3)
        for k, t in enumerate(thresholds):
            for ax in axes:
                ax.axvline(t.reduced_velocity, color="0.5", lw=0.8, ls="-.")
            axes[0].annotate(  # staggered: thresholds can be close together
                f"{t.kind} {t.boundary[:5]}, U* = {t.reduced_velocity:.4g}", (t.reduced_velocity, 0),
                xytext=(4, 10 + 11 * k), textcoords="offset points", fontsize=7.5,
            )  # fmt: skip
        titles = (
            "growth rate λ (symlog; filled: unstable)",
            "frequency ω of the solid branches",
            "wake branch",
        )
        for ax, panel, ylabel in zip(axes, titles, ("λ", "ω", "ω"), strict=True):
            ax.set_title(panel)
            ax.set_xlabel("reduced velocity U*")
            ax.set_ylabel(ylabel)
            ax.grid(alpha=0.3)
        axes[2].ticklabel_format(axis="y", useOffset=False)
        if "wake" in branches:  # nearly constant: a band of ±0.5 around it, not a zoom on its digits
            middle = float(np.mean(np.array(branches["wake"].values).imag))
            axes[2].set_ylim(middle - 0.5, middle + 0.5)
        axes[1].legend()
        axes[2].legend()
        fig.suptitle(title)
        return save_figure(fig, path)


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
