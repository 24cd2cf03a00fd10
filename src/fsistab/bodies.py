"""Bodies: each class owns its shape and every convention that depends on it (docs/model.md §1, §10).

A body is an immutable, validated description of the section's shape (its dataclass fields, which
enter the cache keys) plus class-level conventions that the rest of fsistab asks for instead of
testing the body's name:

* units: the length unit (``length_unit``: the plate's chord, the cylinder's diameter), the
  body's convention of the mass ratio and the reduced velocity against the generic solid equations
  of docs/model.md §3 (``generic_solid``, ``own_mass_ratio``, ``velocity_scale``), the
  ``conventions`` string every result carries;
* defaults: solid parameters, degrees of freedom, the spectrum's shifts and the wake mode's shift;
* discretisation: the mesh presets' element sizes, refinement boxes, domains and outlet layers
  (what a preset means for this body), the wall as a netgen.occ face and its exact projection
  (curved elements), and the shape queries of the mesh-size estimate (:mod:`fsistab.resources`);
* figures: the windows of flow and mode plots.

The plate, the cylinder, the NACA four-digit airfoils (:class:`Airfoil`) and the closed curves read
from a file (:class:`Curve`) are such classes; the last two share what a section given by points
needs (:mod:`fsistab.outlines`, docs/model.md §11). NumPy and NGSolve are imported where a method
needs them, so that the command line reads its options (and pins BLAS threads) before any numerical
package loads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar, Literal

from fsistab.errors import InputError
from fsistab.validate import finite

WALL = "wall"  # the boundary name of the body's surface

# A mesh preset's element sizes for one body: (wall floor, wall coefficient k in min(floor, k/√Re),
# corner, near, wake, far, margin, wake length, wake half-width), in body lengths. Above Re 2900 the
# near size is multiplied by f = √(2900/Re), the wall and corner sizes by f² (fsistab.mesh).
PresetRow = tuple[float, float, float, float, float, float, float, float, float]
# A graded far field: (middle size, middle box (upstream, downstream, lateral), middle band
# (downstream end, half-width)) (fsistab.mesh.MeshSizes).
MiddleRow = tuple[float, tuple[float, float, float], tuple[float, float]]
# A wake box continued downstream with larger elements: (size, downstream end, half-width)
# (fsistab.mesh.MeshSizes.far_wake).
FarWakeRow = tuple[float, float, float]
Window = tuple[tuple[float, float], tuple[float, float]]


def rectangle_distance(x, y, x0, x1, y0, y1):
    """Distance from ``(x, y)`` to the rectangle ``[x0, x1] × [y0, y1]`` (0 inside)."""
    import numpy as np

    dx = np.maximum(np.maximum(x0 - x, x - x1), 0.0)
    dy = np.maximum(np.maximum(y0 - y, y - y1), 0.0)
    return np.hypot(dx, dy)


def interval_overlap(a0, a1, b0, b1):
    """Length of ``[a0, a1] ∩ [b0, b1]``."""
    import numpy as np

    return np.maximum(np.minimum(a1, b1) - np.maximum(a0, b0), 0.0)


def disc_corner_area(x, y, radius: float):
    """Area of the disc ``|X| ≤ radius`` (centred at 0) with ``X ≤ x`` and ``Y ≤ y``.

    ``∫ (s(t) + clamp(y, -s(t), s(t))) dt`` over ``t ≤ x``, ``s(t) = √(radius² - t²)``: where
    ``|t| > w = √(radius² - y²)`` the chord lies wholly below ``y`` (``y ≥ 0``) or above it."""
    import numpy as np

    r = radius
    x = np.clip(x, -r, r)
    y = np.clip(y, -r, r)

    def primitive(a):  # ∫_{-r}^{a} s(t) dt
        return (
            0.5 * (a * np.sqrt(np.maximum(r * r - a * a, 0.0)) + r * r * np.arcsin(a / r)) + np.pi * r * r / 4
        )

    w = np.sqrt(np.maximum(r * r - y * y, 0.0))
    m = np.minimum(x, w)
    band = np.where(x > -w, primitive(m) - primitive(-w), 0.0)  # ∫ s over |t| ≤ w, t ≤ x
    width = np.where(x > -w, m + w, 0.0)
    return np.where(y >= 0, 2 * primitive(x) - band + y * width, band + y * width)


@dataclass(frozen=True)
class Plate:
    """Thin rectangular plate with rounded corners (docs/model.md §1), chord = 1.

    ``aspect_ratio`` is chord/thickness (default 20); ``corner_radius`` is relative to the
    thickness (default 1/10, i.e. radius e/10). Lengths in chords, time ``c/U∞``.
    """

    aspect_ratio: float = 20.0
    corner_radius: float = 0.1
    kind: Literal["plate"] = "plate"

    length_unit: ClassVar[str] = "chord"
    conventions: ClassVar[str] = (
        "chord-based: length c, time c/U, coefficients F/(0.5 rho U^2 c s); "
        "h up, theta counter-clockwise, alpha = -theta (docs/model.md §1-§4)"
    )
    velocity_scale: ClassVar[float] = 1.0  # the body's U* over the generic one (docs/model.md §2)
    mass_scale: ClassVar[float] = 1.0  # the generic m over the body's own (docs/model.md §2)
    axisymmetric: ClassVar[bool] = False  # α0 changes the flow around it
    symmetric: ClassVar[bool] = True  # meshed as a half mirrored about Y = 0 (fsistab.mesh)
    allowed_dofs: ClassVar[tuple[str, ...]] = ("heave", "pitch")
    default_dofs: ClassVar[tuple[str, ...]] = ("heave", "pitch")
    default_mass_ratio: ClassVar[float] = 1000.0  # docs/model.md §2
    default_reduced_velocity: ClassVar[float] = 4.7
    spectrum_shifts: ClassVar[tuple[complex, ...]] = (0.05 + 0.2j,)
    wake_shifts: ClassVar[tuple[complex, ...]] = ()  # no default wake-mode shift: it depends on Re
    flow_window: ClassVar[Window] = ((-1.0, 3.0), (-0.8, 0.8))
    mode_window: ClassVar[Window] = ((-1.0, 2.0), (-0.75, 0.75))
    sensitivity_window: ClassVar[Window] = ((-1.0, 2.5), (-0.8, 0.8))

    # What the presets mean for the plate (docs/how-to/meshes.md, docs/discretisation.md): `quick`
    # is `medium` with 0.1-chord elements in its wake box; `medium` and `fine` reach [-80, 160] ×
    # [-80, 80] with 1-chord elements to 40 chords and across the wake to the outlet, 2-chord ones
    # beyond, and absorbing layers at the outlet and over the outer elements. `fast` is `medium`
    # with its wake box graded (0.05-chord elements to 5 chords, 0.1-chord ones to 20) and 4-chord
    # outer elements (docs/performance.md, "Fewer unknowns").
    mesh_presets: ClassVar[dict[str, PresetRow]] = {
        "coarse": (0.03, 1.0, 0.008, 0.05, 0.15, 4.0, 0.25, 4.0, 0.6),
        "quick": (0.015, 0.5, 0.003, 0.025, 0.1, 2.0, 0.25, 20.0, 1.0),
        "fast": (0.015, 0.5, 0.003, 0.025, 0.05, 4.0, 0.25, 5.0, 1.0),
        "medium": (0.015, 0.5, 0.003, 0.025, 0.05, 2.0, 0.25, 20.0, 1.0),
        "fine": (0.008, 0.25, 0.0015, 0.012, 0.04, 2.0, 0.25, 20.0, 1.0),
    }
    middle_presets: ClassVar[dict[str, MiddleRow]] = {
        "quick": (1.0, (40.0, 80.0, 40.0), (160.0, 20.0)),
        "fast": (1.0, (40.0, 80.0, 40.0), (160.0, 20.0)),
        "medium": (1.0, (40.0, 80.0, 40.0), (160.0, 20.0)),
        "fine": (1.0, (40.0, 80.0, 40.0), (160.0, 20.0)),
    }
    far_wake_presets: ClassVar[dict[str, FarWakeRow]] = {"fast": (0.1, 20.0, 1.0)}
    # (upstream, downstream, lateral) of each preset's domain; None: every other preset's
    domain_presets: ClassVar[dict[str | None, tuple[float, float, float]]] = {
        None: (20.0, 40.0, 20.0),
        "quick": (80.0, 160.0, 80.0),
        "fast": (80.0, 160.0, 80.0),
        "medium": (80.0, 160.0, 80.0),
        "fine": (80.0, 160.0, 80.0),
    }
    # the presets' outlet and far-field layers (fsistab.params.Sponge arguments); none on `coarse`,
    # whose spurious modes come from its far-field elements, which no outlet layer removes
    sponge_presets: ClassVar[dict[str, dict[str, float]]] = {
        "quick": {"far_sigma": 0.2, "far_ramp": 10.0},
        "fast": {"far_sigma": 0.2, "far_ramp": 10.0},
        "medium": {"far_sigma": 0.2, "far_ramp": 10.0},
        "fine": {"far_sigma": 0.2, "far_ramp": 10.0},
    }

    def __post_init__(self):
        ar = finite("chord/thickness ratio", self.aspect_ratio)
        if ar <= 1:
            raise InputError(f"chord/thickness ratio must be > 1, got {ar}")
        rc = finite("corner radius (relative to the thickness)", self.corner_radius)
        if not 0 <= rc < 0.5:
            raise InputError(f"corner radius must be in [0, 0.5) times the thickness, got {rc}")
        object.__setattr__(self, "aspect_ratio", ar)
        object.__setattr__(self, "corner_radius", rc)

    @property
    def thickness(self) -> float:
        return 1.0 / self.aspect_ratio

    @property
    def rear(self) -> float:
        """Abscissa of the rear (trailing edge) in the body frame."""
        return 0.5

    @property
    def half_height(self) -> float:
        """Half the body's extent in ``Y``."""
        return self.thickness / 2

    @property
    def half_area(self) -> float:
        """Area of the body's upper half (the mesh is built on ``Y ≥ 0`` and mirrored)."""
        return self.half_height

    @property
    def radius_of_gyration(self) -> float:
        """``r_θ = sqrt((1 + (e/c)²)/12)`` of a homogeneous rectangle about its centre."""
        return math.sqrt((1 + self.thickness**2) / 12)

    def corner_size(self, corner: float, wall: float) -> float:
        """A preset's corner size fitted to the corner arcs: at most the wall size and the arcs'
        radius, at least an eighth of the wall size."""
        corner = min(corner, wall, self.corner_radius * self.thickness if self.corner_radius else wall)
        return max(corner, wall / 8)

    @classmethod
    def generic_solid(cls, solid):
        """The solid in the generic form of docs/model.md §3: the plate's own."""
        return solid

    @classmethod
    def own_mass_ratio(cls, solid) -> float:
        """The mass ratio in the body's convention (inverse of :meth:`generic_solid`)."""
        return solid.mass_ratio

    def face(self, wall_size: float, corner_size: float):
        """Rounded rectangle of chord 1 and thickness 1/aspect_ratio as a netgen.occ face; the
        long sides carry ``wall_size``, the corner arcs and short sides ``corner_size``.

        Corners are ``Arc`` segments of a ``WorkPlane`` path (``MakeFillet`` fails on 2D faces).
        """
        from netgen.occ import WorkPlane

        e = self.thickness
        r = self.corner_radius * e
        wp = WorkPlane().MoveTo(-0.5 + r, -e / 2)
        if r > 0:
            wp.Line(1 - 2 * r).Arc(r, 90).Line(e - 2 * r).Arc(r, 90).Line(1 - 2 * r).Arc(r, 90)
            wp.Line(e - 2 * r).Arc(r, 90)
        else:
            wp.Line(1).Rotate(90).Line(e).Rotate(90).Line(1).Rotate(90).Line(e)
        face = wp.Face()
        for i, edge in enumerate(face.edges):
            edge.name = WALL
            # path order: long side, corner, short side, corner, ... (or long, short, ... if r = 0)
            is_long_side = i % (4 if r > 0 else 2) == 0
            edge.maxh = wall_size if is_long_side else corner_size
        return face

    def wall_projection(self, shift: float = 0.0):
        """Closest point on the corner arcs, as a CoefficientFunction of ``(x, y)`` (the straight
        sides need no correction): curves the elements at the wall. ``shift``: the plate's centre
        is at ``x = -shift`` (a frame whose origin is an elastic axis, :class:`Pivoted`)."""
        from ngsolve import CF, IfPos, sqrt, x, y

        e = self.thickness
        rc = self.corner_radius * e
        if rc == 0:
            return CF((x, y))
        px = x + shift if shift else x  # the abscissa from the plate's centre
        # centre of the nearest corner arc, then the projection onto it when the point lies in a corner
        cx = IfPos(px, 0.5 - rc, -(0.5 - rc))
        cy = IfPos(y, e / 2 - rc, -(e / 2 - rc))
        dx, dy = px - cx, y - cy
        dist = sqrt(dx * dx + dy * dy) + 1e-300
        abs_x, abs_y = IfPos(px, px, -px), IfPos(y, y, -y)
        in_corner = IfPos(abs_x - (0.5 - rc), IfPos(abs_y - (e / 2 - rc), 1.0, 0.0), 0.0)
        return CF((x + in_corner * (cx + rc * dx / dist - px), y + in_corner * (cy + rc * dy / dist - y)))

    def distance(self, x, y):
        """Distance from ``(x, y)`` to the body (its bounding rectangle; 0 inside)."""
        e = self.half_height
        return rectangle_distance(x, y, -0.5, 0.5, -e, e)

    def corner_distance(self, x, y):
        """Distance to the parts of the wall meshed with the corner size (the leading and trailing
        edges: short sides and rounded corners)."""
        import numpy as np

        e = self.half_height
        return np.minimum(
            rectangle_distance(x, y, -0.5, -0.5, -e, e), rectangle_distance(x, y, 0.5, 0.5, -e, e)
        )

    def solid_area(self, x0, x1, y0, y1):
        """Area of the body inside each cell ``[x0, x1] × [y0, y1]`` (arrays)."""
        return interval_overlap(x0, x1, -0.5, 0.5) * interval_overlap(
            y0, y1, -self.half_height, self.half_height
        )

    def wall_edges(self, wall_size: float, corner_size: float) -> float:
        """Number of element edges on the wall: lengths over local sizes."""
        return 2 / wall_size + 2 * self.thickness / corner_size


@dataclass(frozen=True)
class Cylinder:
    """Circular cylinder of diameter 1 (docs/model.md §10): lengths in diameters, time ``D/U∞``,
    heave only, its own mass ratio and reduced velocity (:meth:`generic_solid`)."""

    kind: Literal["cylinder"] = "cylinder"

    length_unit: ClassVar[str] = "diameter"
    conventions: ClassVar[str] = (
        "diameter-based: length D, time D/U, coefficients F/(0.5 rho U^2 D s) (docs/model.md §10)"
    )
    velocity_scale: ClassVar[float] = 2 * math.pi  # U* = U∞/(f_n D) against the generic U∞/(ω D)
    mass_scale: ClassVar[float] = math.pi / 2  # m_g = π m / 2 (docs/model.md §10)
    axisymmetric: ClassVar[bool] = True  # α0 only turns the free stream: no eigenvalue depends on it
    symmetric: ClassVar[bool] = True
    allowed_dofs: ClassVar[tuple[str, ...]] = ("heave",)
    default_dofs: ClassVar[tuple[str, ...]] = ("heave",)
    default_mass_ratio: ClassVar[float] = 20.0  # docs/model.md §10
    default_reduced_velocity: ClassVar[float] = 8.0
    spectrum_shifts: ClassVar[tuple[complex, ...]] = (0.75j,)
    wake_shifts: ClassVar[tuple[complex, ...]] = (0.75j,)  # the wake mode near onset (Re 40-100)
    flow_window: ClassVar[Window] = ((-2.0, 6.0), (-2.0, 2.0))
    mode_window: ClassVar[Window] = ((-2.0, 8.0), (-2.5, 2.5))
    sensitivity_window: ClassVar[Window] = ((-2.0, 8.0), (-2.5, 2.5))

    mesh_presets: ClassVar[dict[str, PresetRow]] = {
        "coarse": (0.1, 0.6, 0.1, 0.15, 0.35, 4.0, 0.75, 10.0, 2.0),
        "medium": (0.04, 0.3, 0.04, 0.07, 0.15, 3.0, 1.0, 20.0, 3.0),
        "fine": (0.02, 0.15, 0.02, 0.04, 0.1, 2.0, 1.0, 25.0, 4.0),
    }
    middle_presets: ClassVar[dict[str, MiddleRow]] = {}
    far_wake_presets: ClassVar[dict[str, FarWakeRow]] = {}
    # large enough that blockage shifts the wake-mode frequency by a tenth of what a domain half as
    # large does (docs/validation.md, "Fixed cylinder: leading global mode")
    domain_presets: ClassVar[dict[str | None, tuple[float, float, float]]] = {None: (50.0, 100.0, 50.0)}
    sponge_presets: ClassVar[dict[str, dict[str, float]]] = {}

    @property
    def rear(self) -> float:
        return 0.5

    @property
    def half_height(self) -> float:
        return 0.5

    @property
    def half_area(self) -> float:
        return math.pi / 8

    def corner_size(self, corner: float, wall: float) -> float:
        """No corners: the table's corner size."""
        return corner

    @classmethod
    def generic_solid(cls, solid):
        """The heave-only cylinder ``h'' + (2π/U*)² h = 2 C_L/(π m)`` (docs/model.md §10) in the
        generic form ``h'' + (Ω/U*_g)² h = C_L/m_g``: ``m_g = π m/2``, ``U*_g = U*/(2π)``, ``Ω = 1``;
        the pitch parameters are unused (ζ_θ = 0, r_θ = 1)."""
        return replace(
            solid,
            mass_ratio=math.pi * solid.mass_ratio / 2,
            reduced_velocity=solid.reduced_velocity / (2 * math.pi),
            freq_ratio=1.0,
            zeta_theta=0.0,
            r_theta=1.0,
        )

    @classmethod
    def own_mass_ratio(cls, solid) -> float:
        return 2 * solid.mass_ratio / math.pi

    def face(self, wall_size: float, corner_size: float):
        """The circle of diameter 1 as a netgen.occ face, every edge of size ``wall_size``."""
        from netgen.occ import Circle

        face = Circle((0, 0), 0.5).Face()
        for edge in face.edges:
            edge.name = WALL
            edge.maxh = wall_size
        return face

    def wall_projection(self):
        """Closest point on the circle, as a CoefficientFunction of ``(x, y)``."""
        from ngsolve import CF, sqrt, x, y

        r = sqrt(x * x + y * y)
        return CF((0.5 * x / r, 0.5 * y / r))

    def distance(self, x, y):
        import numpy as np

        return np.maximum(np.hypot(x, y) - 0.5, 0.0)

    def corner_distance(self, x, y):
        """No part of the wall has its own size."""
        return None

    def solid_area(self, x0, x1, y0, y1):
        import numpy as np

        corner = disc_corner_area
        solid = np.zeros_like(x0 * y0)
        near = (x1 > -0.5) & (x0 < 0.5) & (y0 < 0.5)  # cells that may meet the disc
        a0, a1, b0, b1 = x0[near], x1[near], y0[near], y1[near]
        solid[near] = corner(a1, b1, 0.5) - corner(a0, b1, 0.5) - corner(a1, b0, 0.5) + corner(a0, b0, 0.5)
        return solid

    def wall_edges(self, wall_size: float, corner_size: float) -> float:
        return math.pi / wall_size


class _Outline:
    """What the sections given by an outline (:mod:`fsistab.outlines`) share: chord-based units and
    the plate's conventions (docs/model.md §11), the presets' sizes with the leading and trailing
    edges refined, a mesh of the whole domain (an outline need not be symmetric), and the wall
    curved on netgen's own geometry (:meth:`wall_projection` is None)."""

    length_unit: ClassVar[str] = "chord"
    conventions: ClassVar[str] = Plate.conventions
    velocity_scale: ClassVar[float] = 1.0
    mass_scale: ClassVar[float] = 1.0
    axisymmetric: ClassVar[bool] = False
    allowed_dofs: ClassVar[tuple[str, ...]] = ("heave", "pitch")
    default_dofs: ClassVar[tuple[str, ...]] = ("heave", "pitch")
    default_mass_ratio: ClassVar[float] = Plate.default_mass_ratio
    default_reduced_velocity: ClassVar[float] = Plate.default_reduced_velocity
    spectrum_shifts: ClassVar[tuple[complex, ...]] = Plate.spectrum_shifts
    wake_shifts: ClassVar[tuple[complex, ...]] = ()
    flow_window: ClassVar[Window] = Plate.flow_window
    mode_window: ClassVar[Window] = Plate.mode_window
    sensitivity_window: ClassVar[Window] = Plate.sensitivity_window
    # the plate's sizes; `corner` is the size at the leading and trailing edges (and at corners)
    mesh_presets: ClassVar[dict[str, PresetRow]] = {
        "coarse": (0.03, 1.0, 0.005, 0.05, 0.15, 4.0, 0.25, 4.0, 0.6),
        "quick": (0.015, 0.5, 0.003, 0.025, 0.1, 2.0, 0.25, 20.0, 1.0),
        "medium": (0.015, 0.5, 0.003, 0.025, 0.05, 2.0, 0.25, 20.0, 1.0),
    }
    middle_presets: ClassVar[dict[str, MiddleRow]] = {
        k: v for k, v in Plate.middle_presets.items() if k != "fine"
    }
    far_wake_presets: ClassVar[dict[str, FarWakeRow]] = {}
    domain_presets: ClassVar[dict[str | None, tuple[float, float, float]]] = Plate.domain_presets
    sponge_presets: ClassVar[dict[str, dict[str, float]]] = Plate.sponge_presets

    @property
    def outline(self):
        """The ``(n, 2)`` outline in the body frame (:mod:`fsistab.outlines`)."""
        raise NotImplementedError

    @property
    def rear(self) -> float:
        return float(self.outline[:, 0].max())

    @property
    def half_height(self) -> float:
        return float(abs(self.outline[:, 1]).max())

    @property
    def half_area(self) -> float:
        from fsistab.outlines import signed_area

        return signed_area(self.outline) / 2

    def corner_size(self, corner: float, wall: float) -> float:
        """The table's size at the edges, at most the wall size, at least an eighth of it."""
        return max(min(corner, wall), wall / 8)

    # the plate's conventions: the solid is already in the generic form of docs/model.md §3
    generic_solid = Plate.__dict__["generic_solid"]
    own_mass_ratio = Plate.__dict__["own_mass_ratio"]

    def face(self, wall_size: float, corner_size: float):
        """The outline splined by netgen.occ (:func:`fsistab.outlines.outline_face`)."""
        from fsistab.outlines import outline_face

        return outline_face(self.outline, wall_size, corner_size, WALL)

    @property
    def symmetric(self) -> bool:
        """Whether the outline is its own mirror image about ``Y = 0``: then meshed as a mirrored
        half like the plate (exactly symmetric), else whole."""
        from fsistab.outlines import is_mirror_symmetric

        return is_mirror_symmetric(self.outline)

    def wall_projection(self, shift: float = 0.0):
        """Closest point on the splined wall, as a CoefficientFunction of ``(x, y)``: for a
        symmetric outline, the projection on its upper half tabulated on a fine grid
        (:func:`fsistab.outlines.upper_projection`) and mirrored; None otherwise (the mesh is whole
        and curved on its netgen.occ geometry, :func:`fsistab.mesh.curve_wall`). ``shift``: the
        outline's frame origin is at ``x = -shift`` (:class:`Pivoted`)."""
        if not self.symmetric:
            return None
        from ngsolve import CF, IfPos, VoxelCoefficient, x, y

        from fsistab.outlines import upper_projection

        start, end, px, py = upper_projection(self.face(1.0, 1.0))
        above = IfPos(y, 1.0, -1.0)
        # the tables are read at (x, |y|) in the outline's own frame: they cover the upper half
        mirrored = CF((x + shift if shift else x, above * y))
        table_x = VoxelCoefficient(start, end, px, linear=True, trafocf=mirrored)
        table_y = VoxelCoefficient(start, end, py, linear=True, trafocf=mirrored)
        return CF((table_x - shift if shift else table_x, above * table_y))

    def distance(self, x, y):
        """Distance to the outline's bounding box (0 inside)."""
        p = self.outline
        return rectangle_distance(x, y, p[:, 0].min(), p[:, 0].max(), p[:, 1].min(), p[:, 1].max())

    def corner_distance(self, x, y):
        """Distance to the breaks of the outline, which carry the corner size."""
        import numpy as np

        from fsistab.outlines import outline_breaks

        p = self.outline
        return np.min([np.hypot(x - p[k, 0], y - p[k, 1]) for k in outline_breaks(p)], axis=0)

    def solid_area(self, x0, x1, y0, y1):
        """Area of the bounding box ``[X min, X max] × [-h, h]`` in each cell (an upper bound)."""
        p, h = self.outline, self.half_height
        return interval_overlap(x0, x1, p[:, 0].min(), p[:, 0].max()) * interval_overlap(y0, y1, -h, h)

    def wall_edges(self, wall_size: float, corner_size: float) -> float:
        import numpy as np

        from fsistab.outlines import outline_breaks

        p = self.outline
        perimeter = float(np.sum(np.hypot(*(np.roll(p, -1, axis=0) - p).T)))
        return perimeter / wall_size + 2 * len(outline_breaks(p)) * math.log2(
            max(wall_size / corner_size, 1.0)
        )


@dataclass(frozen=True)
class Airfoil(_Outline):
    """A NACA four-digit section named ``naca<m><p><tt>`` (docs/model.md §11), chord 1 from
    ``X = -1/2`` (leading edge) to ``1/2``, pitching about mid-chord; ``trailing_edge`` ``closed``
    (the thickness coefficient -0.1036) or ``open`` (-0.1015, a blunt trailing edge)."""

    kind: str = "naca0012"
    trailing_edge: Literal["closed", "open"] = "closed"

    def __post_init__(self):
        from fsistab.outlines import NACA_LAST, naca_digits

        naca_digits(self.kind)
        if self.trailing_edge not in NACA_LAST:
            raise InputError(f"trailing edge must be closed or open, got {self.trailing_edge!r}")

    @property
    def outline(self):
        from fsistab.outlines import naca_outline

        return naca_outline(self.kind, self.trailing_edge)


@dataclass(frozen=True)
class Curve(_Outline):
    """A closed curve given by points (docs/model.md §11), normalised by
    :func:`fsistab.outlines.normalised_outline`: counter-clockwise from its trailing edge, lengths
    in chords (or in the reference length given when it was read), centred on mid-chord."""

    points: tuple[tuple[float, float], ...] = ()
    kind: Literal["curve"] = "curve"

    def __post_init__(self):
        import numpy as np

        from fsistab.outlines import MIN_POINTS, self_intersection, signed_area

        p = np.asarray(self.points, dtype=float).reshape(-1, 2)
        if len(p) < MIN_POINTS or not np.all(np.isfinite(p)):
            raise InputError(f"a curve needs at least {MIN_POINTS} finite points, got {len(p)}")
        if signed_area(p) <= 0 or self_intersection(p) is not None:
            raise InputError(
                "a curve's points must be counter-clockwise and not cross (read it with Curve.read)"
            )
        object.__setattr__(self, "points", tuple((float(x), float(y)) for x, y in p))

    @classmethod
    def from_points(
        cls, points, reference_length: float | None = None, name: str = "the body curve"
    ) -> Curve:
        """The curve through ``points`` (any orientation, the first point repeated or not), checked
        and normalised (:func:`fsistab.outlines.normalised_outline`); coordinates rounded to 12
        digits so that the same file always gives the same cache keys."""
        import numpy as np

        from fsistab.outlines import normalised_outline

        outline = np.round(normalised_outline(points, reference_length, name), 12)
        return cls(points=tuple(map(tuple, outline.tolist())))

    @classmethod
    def read(cls, path, reference_length: float | None = None) -> Curve:
        """The curve of a points file (rows ``x,y``; :func:`fsistab.outlines.read_points`)."""
        from fsistab.outlines import read_points

        return cls.from_points(read_points(path), reference_length, f"the curve of {path}")

    @property
    def outline(self):
        import numpy as np

        return np.array(self.points, dtype=float)


@dataclass(frozen=True)
class Pivoted:
    """A pitching section whose frame's origin is its elastic axis (docs/model.md §3.1): ``body``
    (the plate, a NACA section or a curve, centred on mid-chord) translated by ``-elastic_axis``
    along ``X``, so that the fluid's rotation ``θ'(-Y, X)`` and the moment of docs/model.md §4, both
    about the origin, are about the elastic axis with no change to the fluid equations.

    Every convention is ``body``'s (attributes are looked up there); the shape queries are moved
    with it (the wall face, its exact projection, the distances of the mesh-size estimate), and
    :func:`fsistab.geometry.fluid_half_geometry` translates the whole domain of ``body`` (its
    extents, refinement boxes and absorbing layers are measured from mid-chord, :attr:`offset`): the
    mesh is the mid-chord section's, translated. With ``elastic_axis`` 0 use ``body`` itself
    (:func:`make_body`): its cache keys are then those of the section about mid-chord.
    """

    body: Plate | Airfoil | Curve
    elastic_axis: float

    def __post_init__(self):
        if isinstance(self.body, Pivoted) or "pitch" not in getattr(self.body, "allowed_dofs", ()):
            raise InputError(
                "an elastic axis is for a section that pitches (the plate, a NACA section, a curve)"
            )
        a = finite("elastic axis (--elastic-axis)", self.elastic_axis)
        if abs(a) >= 0.5:
            raise InputError(f"the elastic axis must lie inside the chord, |a| < 1/2, got a = {a:g}")
        object.__setattr__(self, "elastic_axis", a)

    def __getattr__(self, name):  # the body's conventions (only for names not found on Pivoted)
        if name.startswith("__") or name == "body":
            raise AttributeError(name)
        return getattr(self.body, name)

    @property
    def offset(self) -> float:
        """Abscissa of mid-chord in this frame, ``-a``."""
        return -self.elastic_axis

    @property
    def rear(self) -> float:
        return self.body.rear + self.offset

    @property
    def outline(self):
        return self.body.outline + [self.offset, 0.0]

    def face(self, wall_size: float, corner_size: float):
        return self.body.face(wall_size, corner_size).Move((self.offset, 0, 0))

    def wall_projection(self):
        return self.body.wall_projection(shift=self.elastic_axis)

    def distance(self, x, y):
        return self.body.distance(x + self.elastic_axis, y)

    def corner_distance(self, x, y):
        return self.body.corner_distance(x + self.elastic_axis, y)

    def solid_area(self, x0, x1, y0, y1):
        a = self.elastic_axis
        return self.body.solid_area(x0 + a, x1 + a, y0, y1)


def mid_chord_body(body):
    """The section about mid-chord: ``body`` itself, or a :class:`Pivoted` section's own."""
    return body.body if isinstance(body, Pivoted) else body


def frame_offset(body) -> float:
    """Abscissa of the body's mid-chord in its frame: ``-a`` for a :class:`Pivoted` section, else 0."""
    return body.offset if isinstance(body, Pivoted) else 0.0


Body = Plate | Cylinder | Airfoil | Curve | Pivoted
BODY_TYPES: dict[str, type[Body]] = {"plate": Plate, "cylinder": Cylinder, "naca": Airfoil, "curve": Curve}
BODIES = ("plate", "cylinder", "nacaMPTT", "curve")


def body_type(kind: str) -> type[Body]:
    """The class of the body named ``kind`` (``plate``, ``cylinder``, ``naca0012``..., ``curve``)."""
    if kind.startswith("naca"):
        from fsistab.outlines import naca_digits

        naca_digits(kind)
        return Airfoil
    try:
        return BODY_TYPES[kind]
    except KeyError:
        raise InputError(
            f"unknown body {kind!r}: choose plate, cylinder, a NACA four-digit section (e.g. naca0012) "
            "or a curve from a file (--body-file)"
        ) from None


def make_body(
    kind: str,
    aspect_ratio: float = 20.0,
    corner_radius: float = 0.1,
    trailing_edge: str = "closed",
    body_file: str | None = None,
    reference_length: float | None = None,
    elastic_axis: float = 0.0,
) -> Body:
    """Body from its name and shape options; every option is checked, also those this body does not
    use (a value that makes no sense is refused even where it is ignored). With ``body_file`` the
    body is the curve it describes, whatever ``kind``. A non-zero ``elastic_axis`` gives the
    section in the frame of its elastic axis (:class:`Pivoted`)."""
    shape = _make_shape(kind, aspect_ratio, corner_radius, trailing_edge, body_file, reference_length)
    if finite("elastic axis (--elastic-axis)", elastic_axis) == 0:
        return shape
    return Pivoted(shape, elastic_axis)


def _make_shape(kind, aspect_ratio, corner_radius, trailing_edge, body_file, reference_length) -> Body:
    """The section about mid-chord (:func:`make_body`)."""
    plate = Plate(aspect_ratio=aspect_ratio, corner_radius=corner_radius)
    if trailing_edge not in ("closed", "open"):
        raise InputError(f"trailing edge must be closed or open, got {trailing_edge!r}")
    if reference_length is not None and body_file is None:
        raise InputError("a reference length is for a body read from a file (--body-file)")
    if body_file is not None:
        if kind not in ("plate", "curve"):
            raise InputError(f"give either --body {kind} or --body-file, not both")
        return Curve.read(body_file, reference_length)
    cls = body_type(kind)
    if cls is Curve:
        raise InputError("a curve is read from a file: give --body-file shape.csv")
    if cls is Airfoil:
        return Airfoil(kind=kind, trailing_edge=trailing_edge)
    return plate if cls is Plate else cls()
