"""Size of a mesh and memory of a solve, estimated from the mesh specification without meshing.

Used to refuse, before any work, a mesh that cannot be computed (for instance ``--Re 1e6`` on a
mesh command, whose mesh would exhaust the memory).

Element count. Netgen fills the domain with triangles of the local size ``h(x)``: the region's
``maxh`` (near box, wake box, far field), lowered near every smaller size by the grading, which lets
the size grow at most linearly with distance, ``h ≤ h₀ + s·d``. So, with ``d_R`` the distance to
``R`` (the body with the wall size, its short sides and corners with the corner size, the near and
wake boxes of :func:`fsistab.geometry.fluid_half_geometry` with their sizes)::

    h(x) = min(far, wake + s d_wake, near + s d_near, wall + s d_body, corner + s d_corner)
    triangles ≈ C ∫_fluid dA / h(x)²,           s = K · grading

integrated by an adaptive quadtree (:func:`_area_over_h2`) over the upper half and doubled (the
mesh is mirrored). ``C = DENSITY`` and ``K = GRADING_SLOPE`` are fitted to the unknowns that
``mesh_statistics`` counts on real meshes of the plate and the cylinder. The
Taylor–Hood P2–P1 unknowns follow exactly from the triangle count ``T`` and the number ``B`` of
boundary edges (Euler's formula for a domain with one hole): ``ndof = 3V + 2E = 4.5 T + 2.5 B``,
``B`` estimated as the body's and outer boundary's lengths over their sizes. Stated accuracy: a
factor 1.25 on the unknowns (what the tests check on the coarse meshes); a grading far from the
presets' 0.25 is the weakest case.

Memory. Peak resident memory ``MEMORY_BASE + MEMORY_PER_UNKNOWN · n`` of one process that builds
the mesh, solves the steady state by Newton (real LU) and factorises ``J + sM`` once in complex
arithmetic (UMFPACK), single-threaded, fitted to ``ru_maxrss`` of such runs. The fill of the LU
grows a little faster than linearly, so the slope is that of the larger runs. Workflows that keep
several factorisations (stability maps, continuation) need more than this estimate. The
calibration of both models against measured meshes and runs is in docs/performance.md ("Mesh size
and memory estimates").
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from fsistab.bodies import interval_overlap, mid_chord_body, rectangle_distance
from fsistab.errors import InputError
from fsistab.geometry import far_wake_extent, middle_band_extent, middle_box_extent
from fsistab.mesh import MeshSpec

# fitted constants (see the module docstring)
# triangles per h² of area: above the 2.31 of equilateral triangles of side h, as each quadtree
# leaf is counted with the largest h it may contain
DENSITY = 2.85
GRADING_SLOPE = 1.4  # s = GRADING_SLOPE · grading: growth of h per unit distance
MEMORY_BASE = 200e6  # bytes: Python with NGSolve, SciPy and the mesh loaded
MEMORY_PER_UNKNOWN = 12e3  # bytes per unknown: matrices, the real LU of Newton, the complex LU

MAX_UNKNOWNS = 5_000_000  # refused whatever the memory: days of computing per factorisation
SAFETY = 0.8  # fraction of the physical memory a run may plan to use
REFINE = 0.5  # a quadtree cell is split while wider than REFINE · h at its centre
_MAX_LEAVES = 2_000_000  # quadtree budget (about 1 s), reached beyond 3-7 M unknowns: lower bound


@dataclass(frozen=True)
class Estimate:
    """Estimated size of a mesh and the peak memory of a steady solve plus a complex LU."""

    triangles: int
    unknowns: int
    memory_bytes: int
    lower_bound: bool = False  # the integration ran out of budget: the mesh is at least this large

    def describe(self) -> str:
        about = "at least" if self.lower_bound else "about"
        return (
            f"{about} {_thousands(self.unknowns)} unknowns ({_thousands(self.triangles)} triangles), "
            f"peak memory {about} {_gigabytes(self.memory_bytes)}"
        )


def _thousands(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def _gigabytes(n: float) -> str:
    return f"{n / 1e9:.1f} GB" if n < 1e12 else f"{n / 1e12:.1f} TB"


class _SizeField:
    """``h(x, y)`` on the upper half ``y ≥ 0`` of the domain of ``spec`` (the mesh is its mirror)."""

    def __init__(self, spec: MeshSpec):
        # the estimate is that of the section about mid-chord: a Pivoted mesh is its translation
        body, domain, sizes = mid_chord_body(spec.body), spec.domain, spec.sizes
        self.sizes = sizes
        self.slope = GRADING_SLOPE * sizes.grading
        self.body = body
        self.half_height = body.half_height
        # the refinement boxes of fsistab.geometry.fluid_half_geometry
        margin = sizes.near_margin
        self.near = (
            -0.5 - margin,
            0.5 + 2 * margin,
            0.0,
            min(margin + self.half_height, 0.9 * domain.lateral),
        )
        wake_end = min(sizes.wake_length, domain.downstream - 1.0)
        self.wake = (
            -0.5 - 2 * margin,
            max(wake_end, 0.5 + 3 * margin),
            0.0,
            min(sizes.wake_half_width, 0.9 * domain.lateral),
        )
        self.far_wake = None
        if sizes.far_wake is not None:
            start, end, half_width = far_wake_extent(domain, sizes)
            self.far_wake = (start, end, 0.0, half_width)
        self.middle = None
        self.band = None
        if sizes.middle is not None:
            up, down, lateral = middle_box_extent(domain, sizes)
            self.middle = (-up, down, 0.0, lateral)
            if sizes.middle_band is not None:
                end, half_width = middle_band_extent(domain, sizes)
                self.band = (0.0, end, 0.0, half_width)

    def body_distance(self, x, y):
        return self.body.distance(x, y)

    def __call__(self, x, y):
        s, sizes = self.slope, self.sizes
        h = np.full_like(x, sizes.far)
        if self.middle is not None:
            h = np.minimum(h, sizes.middle + s * rectangle_distance(x, y, *self.middle))
        if self.band is not None:
            band = sizes.middle if sizes.band is None else sizes.band
            h = np.minimum(h, band + s * rectangle_distance(x, y, *self.band))
        if self.far_wake is not None:
            h = np.minimum(h, sizes.far_wake[0] + s * rectangle_distance(x, y, *self.far_wake))
        h = np.minimum(h, sizes.wake + s * rectangle_distance(x, y, *self.wake))
        h = np.minimum(h, sizes.near + s * rectangle_distance(x, y, *self.near))
        h = np.minimum(h, sizes.wall + s * self.body_distance(x, y))
        ends = self.body.corner_distance(x, y)  # the parts of the wall with the corner size, if any
        if ends is not None:
            h = np.minimum(h, sizes.corner + s * ends)
        return h


class _Cells:
    """Square cells ``[x0, x0 + width] × [y0, y0 + width]`` of one quadtree level."""

    def __init__(self, x0, y0, width: float):
        self.x0, self.y0, self.width = x0, y0, width

    def children(self, keep) -> _Cells:
        half = self.width / 2
        x0, y0 = self.x0[keep], self.y0[keep]
        return _Cells(
            np.concatenate([x0, x0 + half, x0, x0 + half]),
            np.concatenate([y0, y0, y0 + half, y0 + half]),
            half,
        )


def _fluid_area(field: _SizeField, domain, cells: _Cells):
    """Exact area of fluid (inside the half domain, outside the body) in each cell: additive, so
    a cell's area is the sum of its children's."""
    x0, y0, x1, y1 = cells.x0, cells.y0, cells.x0 + cells.width, cells.y0 + cells.width
    area = interval_overlap(x0, x1, -domain.upstream, domain.downstream) * interval_overlap(
        y0, y1, 0.0, domain.lateral
    )
    solid = field.body.solid_area(x0, x1, y0, y1)
    return np.maximum(area - solid, 0.0)


def _area_over_h2(field: _SizeField, domain) -> tuple[float, bool]:
    """A lower bound of ``∫ dA / h²`` over the fluid of the upper half domain, by an adaptive
    quadtree, and whether the cell budget was exhausted (the bound is then far from sharp).

    The cells lie on a lattice of spacing ``far`` anchored at the origin, the same for every
    domain. A cell wider than ``REFINE · h`` at its centre is split; a leaf counts its fluid area over
    ``(h(centre) + s r)²``, ``r`` its half-diagonal, an upper bound of ``h`` on the cell since ``h``
    is ``s``-Lipschitz. A child's bound is at most its parent's and fluid areas add up, so
    refining never lowers the sum, and a finer field (larger Re, a larger domain with its larger
    boxes) refines the tree: the estimate is monotone in the sizes and the domain (as long as the
    budget is not reached).
    """
    width = field.sizes.far
    ix = np.arange(math.floor(-domain.upstream / width), math.ceil(domain.downstream / width))
    iy = np.arange(0, math.ceil(domain.lateral / width))
    if ix.size * iy.size > _MAX_LEAVES:  # h ≤ far everywhere: the fluid area over far² is a lower bound
        solid = field.body.half_area
        area = (domain.upstream + domain.downstream) * domain.lateral - solid
        return area / (width + field.slope * width / math.sqrt(2)) ** 2, True
    gx, gy = np.meshgrid(ix * width, iy * width)
    cells = _Cells(gx.ravel(), gy.ravel(), width)
    total, leaves, saturated = 0.0, 0, False
    while cells.x0.size:
        area = _fluid_area(field, domain, cells)
        half = cells.width / 2
        h = field(cells.x0 + half, cells.y0 + half)
        split = (area > 0) & (cells.width > REFINE * h)
        if leaves + 4 * np.count_nonzero(split) > _MAX_LEAVES:
            saturated, split = True, np.zeros_like(split)  # out of budget: the rest as leaves
        leaf = (area > 0) & ~split
        bound = h[leaf] + field.slope * half * math.sqrt(2)
        total += float(np.sum(area[leaf] / bound**2))
        leaves += int(np.count_nonzero(leaf))
        cells = cells.children(split)
    return total, saturated


def _boundary_edges(spec: MeshSpec) -> float:
    """Edges on the body and the outer boundary (whole domain): lengths over local sizes."""
    body, domain, sizes = spec.body, spec.domain, spec.sizes
    on_body = body.wall_edges(sizes.wall, sizes.corner)
    outer = 2 * (domain.upstream + domain.downstream) + 4 * domain.lateral
    return on_body + outer / sizes.far


def memory_bytes(unknowns: int) -> int:
    """Peak resident memory of a steady solve and one complex LU with ``unknowns`` unknowns."""
    return int(MEMORY_BASE + MEMORY_PER_UNKNOWN * unknowns)


def estimate(spec: MeshSpec) -> Estimate:
    """Triangles, Taylor–Hood unknowns and peak memory of the mesh of ``spec``, without meshing."""
    field = _SizeField(spec)
    domain = spec.domain
    integral, saturated = _area_over_h2(field, domain)
    triangles = 2 * DENSITY * integral  # the mesh is the upper half and its mirror image
    unknowns = 4.5 * triangles + 2.5 * _boundary_edges(spec)
    return Estimate(
        triangles=round(triangles),
        unknowns=round(unknowns),
        memory_bytes=memory_bytes(unknowns),
        lower_bound=saturated,
    )


def physical_memory() -> int | None:
    """Bytes of physical memory (``os.sysconf``, else ``/proc/meminfo`` MemTotal), None if unknown."""
    try:
        pages, page_size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
        if pages > 0 and page_size > 0:
            return pages * page_size
    except (AttributeError, ValueError, OSError):
        pass
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemTotal:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def check_fits(spec: MeshSpec, memory_available: int | None = None) -> Estimate:
    """The estimate of ``spec``, or InputError (one line, before any meshing) if the mesh would
    exceed :data:`MAX_UNKNOWNS` or its solve would need more than ``memory_available`` bytes
    (default: :data:`SAFETY` × the physical memory; not checked if that is unknown)."""
    found = estimate(spec)
    if memory_available is None:
        physical = physical_memory()
        memory_available = None if physical is None else int(SAFETY * physical)
    too_large = found.unknowns > MAX_UNKNOWNS
    if too_large or (memory_available is not None and found.memory_bytes > memory_available):
        available = "unknown" if memory_available is None else _gigabytes(memory_available)
        raise InputError(
            f"mesh too large: {found.describe()}, {available} available, at most "
            f"{_thousands(MAX_UNKNOWNS)} unknowns allowed: use a coarser --mesh, a smaller --domain "
            "or a lower --Re"
        )
    return found
