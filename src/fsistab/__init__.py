"""fsistab: global linear stability of spring-mounted rigid bodies in incompressible viscous flow.

Conventions (docs/model.md §1-§4, §10): lengths in units of the body's reference length (chord for
the plate, diameter for the cylinder), time in units of length / free-stream speed, forces as
coefficients ``F / (1/2 rho U^2 L s)``. Eigenvalues are ``sigma = lambda + i omega`` of
``sigma M q + J q = 0``.

Importing fsistab changes no global state. From Python, :func:`show_progress` prints the
workflows' progress (logger ``fsistab``, INFO), and :func:`blas_threads` runs a block with BLAS on
one thread as the command line does (each workflow runs inside it).
"""

from fsistab.errors import FsistabError, InputError
from fsistab.progress import blas_threads, show_progress

__version__ = "0.5.0"
__all__ = ["FsistabError", "InputError", "__version__", "blas_threads", "show_progress"]
