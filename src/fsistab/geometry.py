"""Bodies and fluid domains as netgen.occ shapes (docs/model.md §1, §10).

The origin is the body's pitch axis: its centre ``G`` (mid-chord), or its elastic axis for a
:class:`fsistab.bodies.Pivoted` section, whose whole domain is translated (docs/model.md §3.1); the
fluid comes from ``-x``. Boundary
names: ``inlet`` (x = -upstream), ``outlet`` (x = downstream), ``lateral`` (y = ±lateral),
``wall`` (the body); ``interface`` (edges of the refinement regions) and ``symmetry`` (the line
``Y = 0`` where the two mirrored halves of the mesh meet) are internal, not physical boundaries.
"""

from __future__ import annotations

from netgen.occ import Glue, MoveTo, OCCGeometry, X, Y

from fsistab.bodies import Body, frame_offset, mid_chord_body
from fsistab.params import Domain

SYMMETRY = "symmetry"  # internal line Y = 0 where the mirrored halves meet
FAR_FIELD = "inlet|lateral"  # U = 0 (fluid at rest in the laboratory)
DIRICHLET = "inlet|lateral|wall"


def body_face(body: Body, wall_size: float, corner_size: float):
    """The body's wall as a netgen.occ face (its own shape: :meth:`fsistab.bodies.Plate.face`)."""
    return body.face(wall_size, corner_size)


def _box(x0: float, x1: float, height: float, whole: bool = False):
    """Upper half of a refinement box ``[x0, x1] × [0, height]`` (``whole``: ``[-height, height]``)."""
    face = MoveTo(x0, -height if whole else 0).Rectangle(x1 - x0, 2 * height if whole else height).Face()
    face.edges.name = "interface"
    return face


def middle_box_extent(domain: Domain, sizes) -> tuple[float, float, float]:
    """``(upstream, downstream, lateral)`` of the middle refinement box, kept one body length inside
    the domain."""
    up, down, lateral = sizes.middle_box
    return (
        min(up, domain.upstream - 1.0),
        min(down, domain.downstream - 1.0),
        min(lateral, domain.lateral - 1.0),
    )


def middle_band_extent(domain: Domain, sizes) -> tuple[float, float]:
    """``(downstream end, half-width)`` of the middle band behind the body: to the outlet at most,
    one body length inside the lateral sides."""
    end, half_width = sizes.middle_band
    return min(end, domain.downstream), min(half_width, domain.lateral - 1.0)


def far_wake_extent(domain: Domain, sizes) -> tuple[float, float, float]:
    """``(start, end, half-width)`` of the far-wake box: from the wake box's end to ``sizes.far_wake``'s
    end (the outlet at most), one body length inside the lateral sides."""
    _, end, half_width = sizes.far_wake
    start = min(sizes.wake_length, domain.downstream - 1.0)
    return start, min(end, domain.downstream), min(half_width, domain.lateral - 1.0)


def fluid_half_geometry(body: Body, domain: Domain, sizes) -> OCCGeometry:
    """Upper half (``Y ≥ 0``) of the fluid domain, or the whole domain for a body that is not
    meshed as a mirrored half (``body.symmetric`` False: an asymmetric outline, docs/model.md §11),
    with a near-body box, a wake box, if ``sizes.far_wake`` is set a far-wake box continuing it, and
    if ``sizes.middle`` is set a middle box grading the far field.

    A :class:`fsistab.bodies.Pivoted` section's domain is its section's translated by ``-a``
    (domain, boxes and body together: the same mesh in the frame of the elastic axis, docs/model.md
    §3.1). The mesh of the whole domain is this half's mesh mirrored about ``Y = 0`` (see
    :func:`fsistab.mesh.build_mesh`), so that it is exactly symmetric: a symmetric flow then has
    zero lift and moment to solver precision. ``sizes`` is a :class:`fsistab.mesh.MeshSizes`.
    """
    section = mid_chord_body(body)  # the whole domain is built about mid-chord, then translated
    whole = not body.symmetric
    outer = _box(-domain.upstream, domain.downstream, domain.lateral, whole)
    outer.edges.Min(X).name = "inlet"
    outer.edges.Max(X).name = "outlet"
    outer.edges.Max(Y).name = "lateral"
    outer.edges.Min(Y).name = "lateral" if whole else SYMMETRY

    margin = sizes.near_margin
    half_height = body.half_height
    near = _box(-0.5 - margin, 0.5 + 2 * margin, min(margin + half_height, 0.9 * domain.lateral), whole)
    wake_end = min(sizes.wake_length, domain.downstream - 1.0)
    wake = _box(
        -0.5 - 2 * margin,
        max(wake_end, 0.5 + 3 * margin),
        min(sizes.wake_half_width, 0.9 * domain.lateral),
        whole,
    )

    body_shape = body_face(section, sizes.wall, sizes.corner)
    near_region = near - body_shape
    near_region.maxh = sizes.near
    wake_region = wake - near
    wake_region.maxh = sizes.wake
    regions = [wake_region, near_region]
    inner = wake
    if sizes.far_wake is not None:  # the wake box continued to far_wake's end with larger elements
        start, end, half_width = far_wake_extent(domain, sizes)
        far_wake = _box(start, end, half_width, whole)
        far_wake_region = far_wake - wake
        far_wake_region.maxh = sizes.far_wake[0]
        regions.insert(0, far_wake_region)
        inner = wake + far_wake
    if sizes.middle is not None:
        middle_regions, inner = _middle_regions(domain, sizes, inner, whole)
        regions[:0] = middle_regions
    far_region = outer - inner
    far_region.maxh = sizes.far
    shape = Glue([far_region, *regions])
    for edge in shape.edges:
        if edge.name == "interface" and abs(edge.center.y) < 1e-12:
            edge.name = SYMMETRY
    if frame_offset(body):  # the frame of the elastic axis: mid-chord at X = -a
        shape = shape.Move((frame_offset(body), 0, 0))
    return OCCGeometry(shape, dim=2)


def _middle_regions(domain: Domain, sizes, inner, whole: bool) -> tuple[list, object]:
    """The middle box and, if ``sizes.middle_band`` is set, the wake's band to the outlet, outside
    ``inner``: one region of size ``sizes.middle``, or with ``sizes.band`` set the band with that
    size and the rest of the box with ``sizes.middle``. Returns the regions and the new ``inner``."""
    up, down, lateral = middle_box_extent(domain, sizes)
    middle = _box(-up, down, lateral, whole)
    band = None
    if sizes.middle_band is not None:  # the wake's band of middle-sized elements, to the outlet
        end, half_width = middle_band_extent(domain, sizes)
        band = _box(0.0, end, half_width, whole)
    if band is None or sizes.band is None:
        middle = middle if band is None else middle + band
        region = middle - inner
        region.maxh = sizes.middle
        return [region], middle
    band_region = band - inner
    band_region.maxh = sizes.band
    box_region = middle - band - inner
    box_region.maxh = sizes.middle
    return [box_region, band_region], middle + band


def wall_projection(body: Body):
    """Closest point on the exact body boundary, as a CoefficientFunction of ``(x, y)``: curves the
    elements at the wall (the body's own, :meth:`fsistab.bodies.Plate.wall_projection`)."""
    return body.wall_projection()
