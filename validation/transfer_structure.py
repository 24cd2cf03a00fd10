"""How finely ``G(iω)`` varies on the plate's low-frequency band, and what sets it: it decides how
many samples the default map needs below ω = 1.3 (docs/performance.md, "The whole map").

Plate at Re 2900 (``--reynolds``) on a mesh preset (default ``quick``, which has the default
mesh's far field; its steady state cached), optionally with another domain (``--domain UP DOWN
LAT``) or sponge (``--sponge``, fsistab's values): exact samples of the aerodynamic transfer
matrix ``G`` (:func:`fsistab.transfer.transfer_samples`, one factorisation each) on the grid
``ω = W0, W0 + h, …, W1`` (``--window W0 W1 --step h``). Only two combinations of ``G``'s columns
reach the body's equations, since ``ḣ = s h`` and ``θ' = s θ`` (docs/model.md §7)::

    G_heave = G_h + s G_ḣ,        G_pitch = G_θ + s G_θ'

and for each (lift and moment rows) the script prints the **fine structure**: the deviation of
the midpoint from the straight line through its two neighbours, ``|g(ω−h) − 2g(ω) + g(ω+h)| / 2``,
relative to the largest ``|g|`` on the window (median and maximum over the grid), which is what an
interpolant between samples ``2h`` apart must resolve. A ``G`` varying on the scale of 1 in ω
gives about ``h²/2``; a ripple of relative amplitude ``A`` and period ``P`` gives
``2A sin²(πh/P)``, about ``2A (πh/P)²`` for ``P ≫ h``. It also prints the strongest delay ``τ``
of that structure (the ``τ`` maximising ``|Σ r(ω) e^{iωτ}|`` for the residual ``r`` of a cubic
fit): a feature ``e^{−iωτ}`` is what a perturbation travelling for a time ``τ`` before it acts on
the body leaves in ``G``; a window of width ``W`` resolves ``τ`` to about ``2π/W``.

With ``--real-shift A --blocks N`` it also builds the reduced model
(:func:`fsistab.reduced_model.krylov_model`) at the real shift ``s₀ = A`` (a real basis, one real
factorisation) and prints its error against the exact samples and its own estimate along the
window: whether one model off the axis can stand for the samples of the low band.

Usage: python validation/transfer_structure.py [--preset quick] [--window 0.4 0.8] [--step 0.005]
           [--domain 80 240 80 --band 240 20 --sponge 0.2,0.25,0.2,10] [--sponge 0.2,0.5,0.2,10]
           [--size wake_length=80] [--far-wake 0.25 160 1.5] [--real-shift 0.5 --blocks 120]
           [--save FILE.npz]
"""

import argparse
import time
from pathlib import Path

import numpy as np
from sponge_check import add_size_option, size_overrides  # the sibling script's (run from validation/)


def fine_structure(values: np.ndarray) -> tuple[float, float]:
    """(median, max) over the grid of ``|g(ω−h) − 2g(ω) + g(ω+h)| / 2`` relative to ``max |g|``."""
    middle = np.abs(values[2:] - 2 * values[1:-1] + values[:-2]) / 2 / np.abs(values).max()
    return float(np.median(middle)), float(middle.max())


def strongest_delay(omega: np.ndarray, values: np.ndarray, delays: np.ndarray) -> float:
    """The delay ``τ`` maximising ``|Σ r(ω) e^{iωτ}|``, ``r`` the residual of a cubic fit."""
    residual = values - np.polyval(np.polyfit(omega, values, 3), omega)
    return float(delays[np.argmax(np.abs(np.exp(1j * np.outer(delays, omega)) @ residual))])


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="quick")
    parser.add_argument("--reynolds", type=float, default=2900.0)
    parser.add_argument("--domain", type=float, nargs=3, metavar=("UP", "DOWN", "LAT"))
    parser.add_argument(
        "--sponge", default="preset", help="as fsistab's --sponge (give it on another --domain)"
    )
    parser.add_argument("--band", type=float, nargs=2, metavar=("END", "HALF"), help="wake band")
    add_size_option(parser)
    parser.add_argument("--window", type=float, nargs=2, default=[0.4, 0.8], metavar=("W0", "W1"))
    parser.add_argument("--step", type=float, default=0.005)
    parser.add_argument("--real-shift", type=float, help="also a reduced model at this real shift")
    parser.add_argument("--blocks", type=int, default=120, help="Krylov blocks of that model")
    parser.add_argument("--save", type=Path, help="the samples as .npz (omega, transfer)")
    parser.add_argument("--cache", type=Path, default=None)
    args = parser.parse_args()
    low, high = args.window
    if not (args.step > 0 and high - low >= 2 * args.step):
        parser.error(f"--window {low:g} {high:g} --step {args.step:g}: need W1 - W0 >= 2h > 0")
    if args.real_shift is not None and args.blocks < 3:
        parser.error(f"--blocks {args.blocks}: a reduced model needs at least 3 Krylov blocks")

    from fsistab.bodies import Plate
    from fsistab.errors import InputError
    from fsistab.mesh import mesh_spec
    from fsistab.operators import fluid_operators
    from fsistab.params import Domain, Flow, parse_sponge
    from fsistab.reduced_model import krylov_model, relative_error
    from fsistab.steady import solve_steady
    from fsistab.store import default_cache_dir
    from fsistab.transfer import transfer_samples

    sizes = size_overrides(args)  # bad input refused before any mesh
    if args.band is not None:
        sizes["middle_band"] = tuple(args.band)
    domain = Domain(*args.domain) if args.domain else None
    try:
        spec = mesh_spec(Plate(), args.preset, args.reynolds, domain, parse_sponge(args.sponge), **sizes)
    except InputError as exc:
        parser.error(str(exc))
    started = time.perf_counter()
    steady = solve_steady(spec, Flow(args.reynolds), cache_dir=args.cache or default_cache_dir())
    fluid = fluid_operators(steady)
    domain = spec.domain
    print(
        f"Re {args.reynolds:g}, {args.preset}, domain [-{domain.upstream:g}, {domain.downstream:g}] x "
        f"[-{domain.lateral:g}, {domain.lateral:g}], sponge {spec.sponge}: {fluid.n_fluid} unknowns "
        f"({time.perf_counter() - started:.0f} s)",
        flush=True,
    )
    omega = np.arange(round((high - low) / args.step) + 1) * args.step + low
    started = time.perf_counter()
    samples = transfer_samples(fluid, 1j * omega, refine=False)
    transfer = np.array([sample.value for sample in samples])
    print(f"{len(omega)} exact samples in {time.perf_counter() - started:.0f} s", flush=True)
    if args.save:
        np.savez(args.save, omega=omega, transfer=transfer)

    s = 1j * omega[:, None]
    combinations = {
        "heave": transfer[:, :, 0] + s * transfer[:, :, 2],
        "pitch": transfer[:, :, 1] + s * transfer[:, :, 3],
        "theta' column alone": transfer[:, :, 3],
    }
    delays = np.arange(0.0, 400.0, 1.0)
    print(f"fine structure at h = {args.step:g} (median / max, relative), strongest delay")
    for name, values in combinations.items():
        for row, load in ((1, "lift"), (2, "moment")):
            median, largest = fine_structure(values[:, row])
            delay = strongest_delay(omega, values[:, row], delays)
            print(f"  {name:20s} {load:6s}: {median:.1e} / {largest:.1e}, tau {delay:.0f}")

    if args.real_shift is not None:
        started = time.perf_counter()
        model = krylov_model(fluid, args.real_shift, blocks=args.blocks, refine=False)
        print(
            f"model at s0 = {args.real_shift:g}: {model.size} vectors in "
            f"{time.perf_counter() - started:.0f} s; error against the samples / estimate:",
            flush=True,
        )
        for w, exact in list(zip(omega, transfer, strict=True))[:: max(1, len(omega) // 16)]:
            error = relative_error(model.transfer(1j * w), exact)
            print(f"  omega {w:.4f}: {error:.1e} / {model.error_estimate(1j * w):.1e}")


if __name__ == "__main__":
    main()
