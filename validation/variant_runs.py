"""Pieces shared by the validation studies that run one mesh variant at a time: the resumable loop
and the velocity mass of a region (energy shares of modes)."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np
import scipy.sparse as sp


def run_variants(names: Iterable[str], out: Path, compute: Callable[[str], dict]) -> None:
    """``compute(name)`` for each variant not yet recorded in ``out`` (JSON lines, one record per
    variant): each record is printed and appended, so that a rerun resumes; a variant that fails is
    printed with its error and not recorded, and the others go on."""
    done = set()
    if out.exists():
        done = {json.loads(line)["variant"] for line in out.read_text().splitlines() if line.strip()}
    for name in names:
        if name in done:
            print(f"{name}: done")
            continue
        try:
            record = compute(name)
        except Exception as exc:  # one failed variant must not stop the study
            record = {"variant": name, "error": f"{type(exc).__name__}: {exc}"}
        print(json.dumps(record), flush=True)
        if "error" not in record:
            with out.open("a") as handle:
                handle.write(json.dumps(record) + "\n")


def region_mass(fluid, box) -> sp.csr_matrix:
    """Velocity mass restricted to the box ``[x0, x1] × [-h, h]`` (fluid unknowns)."""
    from ngsolve import BilinearForm, IfPos, InnerProduct, dx, x, y

    x0, x1, half = box
    (u, _), (v, _) = fluid.steady.space.TnT()
    form = BilinearForm(fluid.steady.space)
    inside = IfPos(x - x0, IfPos(x1 - x, IfPos(half * half - y * y, 1.0, 0.0), 0.0), 0.0)
    form += inside * InnerProduct(u, v) * dx
    form.Assemble()
    rows, cols, values = form.mat.COO()
    n = fluid.steady.space.ndof
    index = fluid.free_dofs
    matrix = sp.csr_matrix((np.asarray(values), (np.asarray(rows), np.asarray(cols))), shape=(n, n))
    return matrix[index][:, index]
