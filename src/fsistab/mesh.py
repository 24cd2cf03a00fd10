"""Meshes: size presets, generation with netgen.occ, and the on-disk mesh cache.

Sizes are in body lengths. The wall size scales with ``Re^-1/2`` (boundary-layer thickness) down
to the preset's floor, so a preset gives a mesh fitted to the Reynolds number it is built for.
Above Re 2900 the near-body sizes shrink faster (:func:`high_reynolds_factor`, ``f = √(2900/Re)``):
the near box by ``f`` (so it scales with ``Re^-1/2``), the wall and corner sizes by ``f² = 2900/Re``.
At Re 10⁴ the plate's flow separates at its rounded leading edge (radius 0.005 chord)
into a thin bubble hugging the wall, whose length and response to α, hence the static slopes, the
Re 2900 sizes do not resolve; the slopes depend mostly on the wall and corner sizes, little on the
near box (docs/validation.md, "Plate: static slopes"). Up to Re 2900 the sizes, and so the mesh cache
keys and every result computed on them, are those of the table.
Meshes are mirror-symmetric about ``Y = 0``; elements touching the body are curved
(``curve_order``).
"""

from __future__ import annotations

import json
import math
import threading
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from fsistab import store
from fsistab.bodies import WALL, Body
from fsistab.errors import CacheError, InputError
from fsistab.geometry import fluid_half_geometry, wall_projection
from fsistab.params import (
    Domain,
    Sponge,
    _positive,
    check_outlet,
    default_domain,
    default_sponge,
    preset_message,
)

PRESETS = ("coarse", "quick", "fast", "medium", "fine")

#: Held by the mesh builds, the operator assemblies and the tasks of studies and marches (the rest of
#: the API is not for two threads at once). Netgen and NGSolve are not safe in two Python threads: two
#: threads loading and curving meshes crash the process, and so does a mesh build beside an operator
#: assembly, in NGSolve's task manager or not (tests/test_threads.py). Reentrant, so that a
#: task holding it (a study point or a march on a dask worker with several threads) can build its
#: mesh and operators; the threads that a workflow starts itself do sparse algebra only.
NGSOLVE_LOCK = threading.RLock()


@dataclass(frozen=True)
class MeshSizes:
    """Local element sizes (body lengths) and refinement regions.

    ``wall`` on the body, ``corner`` on the rounded corners and short sides of the plate, ``near``
    in a box reaching ``near_margin`` beyond the body (twice that behind it), ``wake`` in a box reaching
    ``wake_length`` downstream with half-width ``wake_half_width``, ``middle`` (if given) in the box
    ``[-u, d] × [-l, l]`` of ``middle_box = (u, d, l)`` and, if ``middle_band = (e, w)`` is given,
    also in the band ``[0, e] × [-w, w]`` behind the body (size ``band`` there, if given),
    ``far_wake = (h, e, w)`` (if given) size
    ``h`` in the box ``[wake end, e] × [-w, w]`` that continues the wake box to ``e``, ``far``
    elsewhere.

    The middle box grades the far field, so that a larger domain costs little; outer elements that
    are too coarse carry weakly damped free-stream modes next to the flutter mode. Large elements
    across the wake fold the low-mass-ratio neutral curves (the perturbation carried down the wake is
    partly reflected where the elements grow), so the band keeps the wake's elements small to the
    outlet (docs/discretisation.md).
    """

    wall: float
    corner: float
    near: float
    wake: float
    far: float
    near_margin: float
    wake_length: float
    wake_half_width: float
    grading: float = 0.25
    curve_order: int = 3
    middle: float | None = None
    middle_box: tuple[float, float, float] | None = None
    middle_band: tuple[float, float] | None = None
    far_wake: tuple[float, float, float] | None = None
    band: float | None = None

    def __post_init__(self):
        for name in (
            "wall",
            "corner",
            "near",
            "wake",
            "far",
            "near_margin",
            "wake_length",
            "wake_half_width",
        ):
            _positive(f"mesh size {name}", getattr(self, name))
        if not 0.05 <= self.grading <= 1:
            raise InputError(f"mesh grading must be in [0.05, 1], got {self.grading}")
        if self.curve_order not in (1, 2, 3, 4):
            raise InputError(f"curve order must be 1-4, got {self.curve_order}")
        if (self.middle is None) != (self.middle_box is None):
            raise InputError("mesh sizes: give both the middle size and the middle box, or neither")
        if self.middle is not None:
            _positive("mesh size middle", self.middle)
            box = tuple(float(_positive("middle box extent", v)) for v in self.middle_box)
            if len(box) != 3:
                raise InputError(f"the middle box is (upstream, downstream, lateral), got {self.middle_box}")
            object.__setattr__(self, "middle_box", box)
        if self.middle_band is not None:
            if self.middle is None:
                raise InputError("mesh sizes: a middle band needs the middle size and box")
            band = tuple(float(_positive("middle band extent", v)) for v in self.middle_band)
            if len(band) != 2:
                raise InputError(f"the middle band is (downstream end, half-width), got {self.middle_band}")
            object.__setattr__(self, "middle_band", band)
        if self.band is not None:
            if self.middle_band is None:
                raise InputError("mesh size band: this mesh has no middle band behind the body")
            _positive("mesh size band", self.band)
        if self.far_wake is not None:
            if not isinstance(self.far_wake, tuple | list) or len(self.far_wake) != 3:
                raise InputError(f"the far wake is (size, downstream end, half-width), got {self.far_wake}")
            box = tuple(float(_positive("far wake size and extent", v)) for v in self.far_wake)
            if box[1] <= self.wake_length:
                raise InputError(
                    f"the far wake must end beyond the wake box ({self.wake_length:g}), got {box[1]:g}"
                )
            object.__setattr__(self, "far_wake", box)

    def key_inputs(self) -> dict:
        """The sizes as the mesh key sees them: without ``middle_band``, ``far_wake`` or ``band``
        when there is none, so that the meshes made before they existed keep their keys (and their
        cached steady states)."""
        inputs = asdict(self)
        for name in ("middle_band", "far_wake", "band"):
            if inputs[name] is None:
                del inputs[name]
        return inputs


HIGH_REYNOLDS = 2900.0  # above it the near-body sizes shrink further (high_reynolds_factor)


def high_reynolds_factor(reynolds: float) -> float:
    """``f``: 1 up to Re 2900, ``√(2900/Re)`` above; the near size is multiplied by ``f``, the wall
    and corner sizes by ``f²``."""
    if reynolds <= HIGH_REYNOLDS:
        return 1.0
    return math.sqrt(HIGH_REYNOLDS / reynolds)


def preset_sizes(body: Body, preset: str, reynolds: float) -> MeshSizes:
    """Element sizes of a named preset fitted to ``reynolds``: the wall size ``min(floor, k/√Re)``,
    and above Re 2900 the near size times ``f = √(2900/Re)``, the wall and corner sizes times ``f²``."""
    if preset not in PRESETS:
        raise InputError(f"unknown mesh preset {preset!r}: choose one of {', '.join(PRESETS)}")
    if preset not in body.mesh_presets:
        raise InputError(preset_message(body, preset))
    reynolds = _positive("Reynolds number", reynolds)
    floor, k, corner, near, wake, far, margin, wake_length, wake_half = body.mesh_presets[preset]
    wall = min(floor, k / math.sqrt(reynolds))
    if reynolds > HIGH_REYNOLDS:  # a branch, so that the sizes up to Re 2900 are the table's, bit for bit
        factor = high_reynolds_factor(reynolds)
        wall, corner, near = wall * factor**2, corner * factor**2, near * factor
    corner = body.corner_size(corner, wall)
    middle, middle_box, middle_band = body.middle_presets.get(preset, (None, None, None))
    far_wake = body.far_wake_presets.get(preset)
    return MeshSizes(
        wall=wall,
        corner=min(corner, wall),
        near=max(near, wall),
        wake=wake,
        far=far,
        near_margin=margin,
        wake_length=wake_length,
        wake_half_width=wake_half,
        middle=middle,
        middle_box=middle_box,
        middle_band=middle_band,
        far_wake=far_wake,
    )


@dataclass(frozen=True)
class MeshSpec:
    """Everything a mesh depends on: body, domain, local sizes (and the preset it came from); and
    the outlet ``sponge`` of the linear operators on it (:class:`fsistab.params.Sponge`), which is
    not part of the mesh (:meth:`key`) nor of the steady state, but of everything linearised
    (:meth:`linear_identity`); the ``outlet`` condition (:data:`fsistab.params.OUTLETS`,
    docs/model.md §4), part of the steady state and of everything linearised, not of the mesh."""

    body: Body
    domain: Domain
    sizes: MeshSizes
    preset: str = "custom"
    sponge: Sponge | None = None
    outlet: str = "stress"

    def __post_init__(self):
        check_outlet(self.outlet)
        if self.sponge is not None and self.sponge.far_sigma > 0 and self.sizes.middle_box is None:
            raise InputError(
                "a far-field sponge lies outside the mesh's middle box: this mesh has none "
                "(use a preset with a graded far field, e.g. medium)"
            )

    def key(self) -> str:
        inputs = {"body": asdict(self.body), "domain": asdict(self.domain), "sizes": self.sizes.key_inputs()}
        return store.cache_key("mesh", inputs)

    def linear_identity(self) -> dict:
        """What results of the linear operators depend on besides the flow: the mesh and the sponge
        (flat attributes; saved curves, maps, samples and study points carry them, so that results
        with and without a sponge are never mixed)."""
        sponge = "none" if self.sponge is None else json.dumps(self.sponge.key_inputs(), sort_keys=True)
        identity = {"mesh_key": self.key(), "sponge": sponge}
        if self.outlet != "stress":  # the default outlet keeps the identities it always had
            identity["outlet"] = self.outlet
        return identity

    def linear_key(self) -> str:
        """A file-name key of :meth:`linear_identity`: the mesh key itself without a sponge (and
        with the default outlet)."""
        if self.sponge is None and self.outlet == "stress":
            return self.key()
        return store.cache_key("linear", self.linear_identity())

    def describe(self) -> dict:
        return {
            "body": asdict(self.body),
            "domain": asdict(self.domain),
            "sizes": asdict(self.sizes),
            "preset": self.preset,
            "sponge": None if self.sponge is None else asdict(self.sponge),
            "outlet": self.outlet,
        }


def mesh_spec(
    body: Body,
    preset: str = "medium",
    reynolds: float = 100.0,
    domain: Domain | None = None,
    sponge: Sponge | None | str = "preset",
    outlet: str = "stress",
    **sizes,
) -> MeshSpec:
    """Mesh specification from a preset fitted to ``reynolds``; keyword arguments override sizes.
    ``sponge`` ``"preset"`` is the preset's (:func:`fsistab.params.default_sponge`) on the preset's
    own domain, and none on another domain: where a layer may start depends on the domain (more than
    a wake wavelength behind the body), so on a domain of one's own it is chosen explicitly."""
    base = preset_sizes(body, preset, reynolds)
    try:
        base = replace(base, **sizes)
    except TypeError as exc:
        raise InputError(f"unknown mesh size parameter: {exc}") from None
    own_domain = default_domain(body, preset)
    domain = domain or own_domain
    if isinstance(sponge, str):
        if sponge != "preset":
            raise InputError(f"sponge must be a Sponge, None or 'preset', got {sponge!r}")
        sponge = default_sponge(body, preset) if domain == own_domain else None
    return MeshSpec(body=body, domain=domain, sizes=base, preset=preset, sponge=sponge, outlet=outlet)


def spec_for(case) -> MeshSpec:
    """The mesh specification of a :class:`fsistab.params.Case`: its preset fitted to its
    ``fitted_reynolds`` (its ``mesh_reynolds``, or its flow's Re) with its ``mesh_sizes`` in place
    of the fitted ones, its body, domain, sponge and outlet condition."""
    return mesh_spec(
        case.body,
        case.preset,
        case.fitted_reynolds,
        case.domain,
        case.sponge,
        case.outlet,
        **dict(case.mesh_sizes),
    )


def _generate(spec: MeshSpec):
    """Mesh the upper half of the domain and mirror it about ``Y = 0`` (exactly symmetric); a body
    that is not ``symmetric`` (an outline, docs/model.md §11) is meshed whole."""
    import netgen.meshing

    geometry = fluid_half_geometry(spec.body, spec.domain, spec.sizes)
    half = geometry.GenerateMesh(maxh=spec.sizes.far, grading=spec.sizes.grading)
    if not spec.body.symmetric:
        return half
    return half.Mirror(netgen.meshing.Pnt(0, 0, 0), netgen.meshing.Vec(0, 1, 0))


def curve_wall(mesh, body: Body, order: int, projection=None) -> None:
    """Curve the elements at the wall: a P``order`` deformation moving wall points onto the exact
    boundary (``projection``, :func:`fsistab.geometry.wall_projection` when not given), zero at
    every dof off the wall; for a body without a projection (an asymmetric outline, whose exact wall
    is its netgen.occ geometry) netgen's own curving on the geometry the mesh carries."""
    from ngsolve import CF, GridFunction, VectorH1, x, y

    if order < 2:
        return
    projection = wall_projection(body) if projection is None else projection
    if projection is None:  # the mesh carries its netgen.occ geometry (build_mesh)
        mesh.Curve(order)
        return
    space = VectorH1(mesh, order=order)
    deformation = GridFunction(space)
    deformation.Set(projection - CF((x, y)), definedon=mesh.Boundaries(WALL))
    mesh.SetDeformation(deformation)


def mesh_path(spec: MeshSpec, cache_dir: Path) -> Path:
    """Where the mesh of ``spec`` is cached (its checksum beside it, :func:`fsistab.store.sidecar_path`)."""
    return Path(cache_dir) / "meshes" / f"{spec.key()}.vol.gz"


def build_mesh(spec: MeshSpec, cache_dir: Path | None = None):
    """The NGSolve mesh of ``spec``, read from the cache or generated and cached, wall curved.

    The cache stores Netgen's ``.vol.gz`` under the spec's key, with a sha256 sidecar written after
    it. Before Netgen reads a cached file its checksum and whole gzip stream are verified (a damaged
    file makes Netgen crash the process): a damaged or unverifiable entry is reported, moved aside and
    rebuilt. Processes sharing the cache check and build an entry one at a time
    (:func:`fsistab.store.entry_lock`). A file that Netgen still cannot read, or that lacks the
    expected boundaries, raises CacheError.
    """
    import tempfile

    if cache_dir is None:
        with tempfile.TemporaryDirectory() as scratch:
            return build_mesh(spec, scratch)
    with NGSOLVE_LOCK:
        return _read_mesh(spec, cached_mesh_file(spec, Path(cache_dir)))


def cached_mesh_file(spec: MeshSpec, cache_dir: Path) -> Path:
    """The verified ``.vol.gz`` of ``spec`` in ``cache_dir``: checked, or generated with its sidecar,
    by one process at a time (:func:`fsistab.store.entry_lock`); a damaged entry is moved aside
    and rebuilt."""
    path = mesh_path(spec, cache_dir)
    with store.entry_lock(path):  # one process at a time checks or builds this entry
        if path.exists():
            try:
                store.verify_sidecar(path)
            except CacheError as exc:
                store.discard_damaged(path, exc)
        if not path.exists():
            # the file rounds coordinates: what is computed always comes from the file, so a cached
            # mesh and a fresh one are identical
            with NGSOLVE_LOCK, store.atomic_path(path, ".vol.gz") as tmp:
                _generate(spec).Save(str(tmp))
            store.write_sidecar(path)  # after the mesh: a mesh without its sidecar is rebuilt
    return path


def _read_mesh(spec: MeshSpec, path: Path):
    """The NGSolve mesh of the verified file ``path``, its wall curved (under :data:`NGSOLVE_LOCK`)."""
    import netgen.meshing
    import ngsolve

    ngmesh = netgen.meshing.Mesh(dim=2)
    try:
        ngmesh.Load(str(path))
    except Exception as exc:
        raise CacheError(f"cannot read cached mesh {path}: {exc}; delete it to rebuild") from None
    if len(ngmesh.Elements2D()) == 0:
        raise CacheError(f"cached mesh {path} is empty (corrupt); delete it to rebuild")
    projection = wall_projection(spec.body)
    if projection is None:  # curved on the geometry itself (an asymmetric outline's splines)
        ngmesh.SetGeometry(fluid_half_geometry(spec.body, spec.domain, spec.sizes))
    mesh = ngsolve.Mesh(ngmesh)
    missing = {"inlet", "outlet", "lateral", WALL} - set(mesh.GetBoundaries())
    if missing:
        raise CacheError(f"mesh {path} lacks boundaries {sorted(missing)}; delete it to rebuild")
    curve_wall(mesh, spec.body, spec.sizes.curve_order, projection)
    return mesh


def element_sizes(mesh) -> np.ndarray:
    """Longest edge of every triangle (straight-sided measure)."""
    coords = mesh.ngmesh.Coordinates()
    nodes = mesh.ngmesh.Elements2D().NumPy()["nodes"][:, :3].astype(np.int64) - 1
    p = coords[nodes]
    edges = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 1], p[:, 0] - p[:, 2]], axis=1)
    return np.linalg.norm(edges, axis=2).max(axis=1)


def mesh_statistics(mesh) -> dict:
    """Triangles, Taylor–Hood P2–P1 unknowns, smallest and largest element size."""
    from ngsolve import H1, VectorH1

    space = VectorH1(mesh, order=2) * H1(mesh, order=1)
    h = element_sizes(mesh)
    return {
        "triangles": int(mesh.ne),
        "vertices": int(mesh.nv),
        "ndof": int(space.ndof),
        "h_min": float(h.min()),
        "h_max": float(h.max()),
    }
