"""fsistab: global linear stability of spring-mounted rigid bodies in incompressible viscous flow.

Conventions (MODEL.md §1-§4, §10): lengths in units of the body's reference length (chord for
the plate, diameter for the cylinder), time in units of length / free-stream speed, forces as
coefficients ``F / (1/2 rho U^2 L s)``. Eigenvalues are ``sigma = lambda + i omega`` of
``sigma M q + J q = 0``.
"""

from fsistab.errors import FsistabError, InputError

__version__ = "0.4.0"
__all__ = ["FsistabError", "InputError", "__version__"]
