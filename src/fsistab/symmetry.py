"""The mirror symmetry of a section symmetric about its chord line at zero incidence
(docs/model.md §7.3): the fluid operators restricted to the antisymmetric fields, which are all
that heave and pitch excite and all that the lift and the moment see.

The reflection ``R (U, V, P)(X, Y) = (U, −V, P)(X, −Y)`` maps the Taylor–Hood space of a mesh
mirrored about ``Y = 0`` (:func:`fsistab.mesh.build_mesh`) onto itself: it sends each vertex and
edge to its mirror image, the ``U`` and ``P`` coefficients with sign ``+1`` and the ``V`` ones with
``−1`` (the quadratic edge functions are even on their edge, so an edge's orientation does not
matter). With a steady flow symmetric under ``R`` the Jacobian and the mass commute with it, and
the solid columns ``J_fs``, ``M_fs`` (the wall moving in heave or turning in pitch, the free stream
turned) are antisymmetric, ``R b = −b``. So ``X = K_ff(s)⁻¹(J_fs + s M_fs)`` lies in the
antisymmetric subspace, and with ``Q`` an orthonormal basis of it (:func:`antisymmetric_basis`)

    X = Q K_a(s)⁻¹ Qᵀ(J_fs + s M_fs),     K_a(s) = Qᵀ J_ff Q + s Qᵀ M_f Q,

the same ``G(s)`` from a matrix of half the size, whose factorisation costs a fraction of the
whole one's (docs/performance.md, "Mirror symmetry"). :func:`antisymmetric_operators` makes these
blocks (the load rows ``ℓ_f Q``: the drag row vanishes on them, as it must, the drag of an
antisymmetric field being zero), and returns the operators unchanged when the body is not meshed as
a mirrored half, the incidence is not zero, or the steady flow or the solid columns are not
symmetric to ``SYMMETRY_TOLERANCE`` (a steady flow that broke the symmetry). The transfer-function
paths (thresholds, maps, flow-plane curves) use them; modes of the result are mapped back to the
whole space with :func:`whole_mode`.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from fsistab import umfpack
from fsistab.operators import FluidOperators

# relative size of the antisymmetric part of the steady state, and of the symmetric part of the
# solid columns, below which the restriction is exact to the solves' own accuracy
SYMMETRY_TOLERANCE = 1e-9


def reflection(steady) -> tuple[np.ndarray, np.ndarray] | None:
    """``(image, sign)`` over every dof of ``steady``'s space: ``R e_i = sign[i] e_{image[i]}``
    (module docstring); None if a vertex or an edge of the mesh has no mirror image (a body meshed
    whole)."""
    from ngsolve import EDGE, VERTEX, NodeId

    mesh, space = steady.mesh, steady.space
    points = np.array([v.point for v in mesh.vertices])
    vertex_image = _mirror_points(points)
    if vertex_image is None:
        return None
    edges = {tuple(sorted(v.nr for v in e.vertices)): e.nr for e in mesh.edges}
    image = np.full(space.ndof, -1)

    def dofs(kind, node: int) -> list[int]:
        return list(space.GetDofNrs(NodeId(kind, node)))

    for vertex in range(mesh.nv):
        image[dofs(VERTEX, vertex)] = dofs(VERTEX, int(vertex_image[vertex]))
    for ends, edge in edges.items():
        other = edges.get(tuple(sorted(int(vertex_image[v]) for v in ends)))
        if other is None:
            return None
        image[dofs(EDGE, edge)] = dofs(EDGE, other)
    if np.any(image < 0):  # dofs not on vertices or edges (a higher order): not handled
        return None
    velocity = space.components[0].ndof
    sign = np.ones(space.ndof)
    sign[velocity // 2 : velocity] = -1.0  # the V components of the vector velocity space
    return image, sign


def _mirror_points(points: np.ndarray) -> np.ndarray | None:
    """The index of each point's mirror image ``(X, −Y)`` among ``points``, or None if one has none."""
    from scipy.spatial import cKDTree

    scale = float(np.abs(points).max())
    distance, image = cKDTree(points).query(points * np.array([1.0, -1.0]))
    return image if float(distance.max()) <= 1e-9 * scale else None


def antisymmetric_basis(image: np.ndarray, sign: np.ndarray, free: np.ndarray) -> sp.csr_matrix | None:
    """The orthonormal basis ``Q`` (free dofs × antisymmetric unknowns) of the vectors on the free
    dofs ``free`` with ``R q = −q``: ``(e_i − sign_i e_j)/√2`` for each pair of mirror dofs
    ``i < j``, ``e_i`` for a dof on ``Y = 0`` that ``R`` reverses (``V`` there), none for one it
    keeps (``U`` and ``P`` on ``Y = 0`` vanish in an antisymmetric field); None if the mirror image
    of a free dof is not free (boundary conditions that are not symmetric)."""
    position = np.full(len(image), -1)
    position[free] = np.arange(len(free))
    mirror = position[image[free]]
    if np.any(mirror < 0):
        return None
    own = np.arange(len(free))
    pairs = own < mirror
    on_axis = (own == mirror) & (sign[free] < 0)
    first = np.concatenate([own[pairs], own[on_axis]])
    columns = np.arange(len(first))
    half = 1.0 / math.sqrt(2.0)
    rows = np.concatenate([first, mirror[pairs]])
    cols = np.concatenate([columns, columns[: int(pairs.sum())]])
    values = np.concatenate(
        [np.full(int(pairs.sum()), half), np.ones(int(on_axis.sum())), -sign[free][pairs] * half]
    )
    return sp.csr_matrix((values, (rows, cols)), shape=(len(free), len(first)))


def _reflected(vector: np.ndarray, image: np.ndarray, sign: np.ndarray) -> np.ndarray:
    """``R v`` for a vector over every dof."""
    result = np.empty_like(vector)
    result[image] = sign * vector
    return result


def antisymmetric_operators(fluid: FluidOperators) -> FluidOperators:
    """``fluid``'s blocks restricted to the antisymmetric fields (module docstring), with the basis
    ``Q`` as ``basis``; ``fluid`` itself where the restriction does not apply or would not be exact.
    The steady state, its dofs and the loads stay those of the whole space."""
    if fluid.basis is not None or fluid.theta0 != 0.0 or not umfpack.available():
        return fluid
    found = reflection(fluid.steady)
    if found is None:
        return fluid
    image, sign = found
    state = fluid.steady.state.vec.FV().NumPy()
    if _relative(_reflected(state, image, sign) - state, state) > SYMMETRY_TOLERANCE:
        return fluid
    basis = antisymmetric_basis(image, sign, fluid.free_dofs)
    inputs = np.hstack([fluid.jfs, fluid.mfs])
    if basis is None or _relative(inputs - basis @ (basis.T @ inputs), inputs) > SYMMETRY_TOLERANCE:
        return fluid
    left = basis.T.tocsr()
    return replace(
        fluid,
        jff=(left @ fluid.jff @ basis).tocsr(),
        mff=(left @ fluid.mff @ basis).tocsr(),
        jfs=left @ fluid.jfs,
        mfs=left @ fluid.mfs,
        load_f=(fluid.load_f @ basis).tocsr(),
        load_mass_f=(fluid.load_mass_f @ basis).tocsr(),
        mff_near=(left @ fluid.mff_near @ basis).tocsr(),
        basis=basis,
        analyses={},
    )


def _relative(difference: np.ndarray, reference: np.ndarray) -> float:
    scale = float(np.abs(reference).max())
    return float(np.abs(difference).max()) / scale if scale else 0.0


def whole_mode(fluid: FluidOperators, mode: np.ndarray) -> np.ndarray:
    """A coupled vector ``(q̂_s, q̂_f)`` of ``fluid`` (restricted or not; ``q̂_s`` on the active
    solid states) with its fluid part on the fluid unknowns of the whole space: ``(q̂_s, Q q̂_f)``,
    of the same norm (``Q`` is orthonormal)."""
    if fluid.basis is None:
        return mode
    solid = len(mode) - fluid.n_fluid
    return np.concatenate([mode[:solid], fluid.basis @ mode[solid:]])
