"""A candidate mesh for a preset (plate, Re 2900) against the resolved references of the
discretisation report: the flutter thresholds at m = 10, 30, 100, 1000 and 10⁴ against the default
mesh with its far wake resolved (docs/discretisation.md, "The far wake", 492 362 unknowns), the VIV
windows at m = 10 and 1000 and the fixed plate's wake mode against the default mesh (the same
report, "The presets"). Each figure is one ``fsistab`` command with ``--json`` (``fsistab
critical`` with the report's U* ranges, ``fsistab spectrum --dofs none``), so the candidate is
given as that command's mesh options; steady states and meshes are cached (``--cache``).

Prints a table: quantity, reference, candidate, difference, and each command's factorisations.
The map itself (turning points, codimension-two point, cost) is ``benchmarks/map_breakdown.py``
with the same options (docs/performance.md, "The whole map").

Usage: python validation/preset_candidate.py [--cache DIR] -- --mesh coarse --domain 40 80 40 \\
           --mesh-sizes near=0.025,far=1,wake_length=79 --sponge 0.2,0.25
"""

import argparse
import json
import subprocess
import tempfile

# (m, U* range, (onset, restabilisation)): the default mesh with the far wake resolved
FLUTTER = (
    (10, (0.5, 15), (0.913127, 2.991134)),
    (30, (0.5, 15), (0.972067, 6.668009)),
    (100, (0.5, 15), (1.549271, 12.861258)),
    (1000, (0.5, 15), (4.559942, None)),
    (10000, (8, 20), (14.175524, None)),
)
# (m, U* range, window edges): the default mesh
VIV = (
    (10, (0.03, 0.12), (0.064381, 0.069272, 0.083323, 0.091636)),
    (1000, (0.06, 0.09), (0.071058, 0.074126)),
)
WAKE_MODE = complex(-0.0317, 11.0983)  # the default mesh's fixed-plate wake mode


def _fsistab(command: str, options: list[str], cache: str | None, *extra: str) -> dict:
    base = ["fsistab", command, "--body", "plate", "--Re", "2900", "--json"]
    base += ["--cache", cache] if cache else []
    with tempfile.TemporaryDirectory() as out:
        run = subprocess.run([*base, "--out", out, *options, *extra], capture_output=True, text=True)
    if run.returncode:
        raise SystemExit(f"fsistab {command} failed: {run.stderr.strip().splitlines()[-1]}")
    return json.loads(run.stdout)


def _crossings(options, cache, mass_ratio, velocities, kind) -> tuple[list[float], int]:
    found = _fsistab(
        "critical", options, cache, "--mass-ratio", str(mass_ratio), "--points", "40",
        "--reduced-velocity-range", *(str(v) for v in velocities),
    )  # fmt: skip
    points = [p["reduced_velocity"] for p in found["critical_points"] if p["kind"] == kind]
    return sorted(points), found["factorisations"]


def _row(quantity: str, reference: float, value: float | None, note: str = "") -> str:
    if value is None:
        return f"| {quantity} | {reference:.6g} | not found | — | {note} |"
    change = 100 * (value - reference) / reference
    return f"| {quantity} | {reference:.6g} | {value:.6g} | {change:+.2f} % | {note} |"


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--cache", default=None, help="fsistab's cache (default: its own)")
    parser.add_argument("options", nargs=argparse.REMAINDER, help="-- then the candidate's mesh options")
    args = parser.parse_args()
    options = [o for o in args.options if o != "--"]
    cache = args.cache
    steady = _fsistab("steady", options, cache)  # the mesh and steady state, cached
    print(f"candidate: {' '.join(options)}; {steady['ndof']} unknowns\n")
    print("| quantity | reference | candidate | difference | factorisations |\n|---|---|---|---|---|")
    for mass_ratio, velocities, (onset, restabilisation) in FLUTTER:
        found, count = _crossings(options, cache, mass_ratio, velocities, "flutter")
        print(_row(f"m = {mass_ratio}: flutter onset", onset, found[0] if found else None, str(count)))
        last = found[-1] if len(found) > 1 else None
        if restabilisation is not None:
            print(_row(f"m = {mass_ratio}: restabilisation", restabilisation, last))
    for mass_ratio, velocities, edges in VIV:
        found, count = _crossings(options, cache, mass_ratio, velocities, "viv")
        for k, edge in enumerate(edges):
            value = found[k] if len(found) == len(edges) else None
            note = str(count) if k == 0 else ""
            print(_row(f"m = {mass_ratio}: VIV window edge {k + 1}", edge, value, note))
    spectrum = _fsistab(
        "spectrum", options, cache, "--dofs", "none", "--shift", "11.1j", "--n-eigenvalues", "1",
        "--no-vtk", "--mode-figures", "0",
    )  # fmt: skip
    mode = spectrum["eigenvalues"][0]
    print(_row("fixed plate's wake mode: damping", -WAKE_MODE.real, -mode["growth_rate"]))
    print(_row("fixed plate's wake mode: frequency", WAKE_MODE.imag, mode["frequency"]))


if __name__ == "__main__":
    main()
