"""Exceptions with messages meant for the user: one line that names the problem and what to try."""


class FsistabError(Exception):
    """Base class of every error fsistab raises on purpose."""


class InputError(FsistabError, ValueError):
    """A parameter, file or cache entry is invalid; raised before any heavy work."""


class ConvergenceError(FsistabError, RuntimeError):
    """An iterative solver (Newton, eigen-solver, continuation) did not converge."""


class CacheError(FsistabError):
    """A cache file is unreadable, corrupt, or does not match the request."""
