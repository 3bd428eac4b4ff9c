"""The optional compiler for the reactor's kernels (``SynthesisConfig.kernel = "numba"``, the extra ``[fast]``).

NumPy is the reference implementation of every kernel; a compiled kernel is an alternative evaluation of the
same arithmetic, accepted under the tolerance declared in docs/design.md §7 (not bitwise: the compiler's loops
and the C library's functions round differently). numba is imported only when a compiled kernel is first asked
for, so the package imports and runs without it; :func:`once` makes each kernel module's compiled objects once per
process.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from typing import Any, TypeVar

from ..errors import ConfigError

__all__ = ["KERNELS", "available", "njit", "once", "require"]

T = TypeVar("T")

KERNELS = ("numpy", "numba")
"""The values of ``SynthesisConfig.kernel``: ``"numpy"`` (the reference, the default) and ``"numba"``."""


def available() -> bool:
    """Whether numba can be imported (the ``[fast]`` extra is installed)."""
    return importlib.util.find_spec("numba") is not None


def require(kernel: str) -> None:
    """Raise :class:`~socialaff_sim.errors.ConfigError` naming the setting and the extra when ``kernel`` is
    ``"numba"`` and numba is missing (a synthesizer checks it when it is made, not at its first re-planning)."""
    if kernel == "numba" and not available():
        raise ConfigError("kernel='numba': numba is not installed (pip install 'socialaff-sim[fast]'); "
                          "use kernel='numpy'")


def njit(function: Callable[..., Any]) -> Callable[..., Any]:
    """``function`` compiled by numba in no-Python mode, without fast-math (IEEE semantics: no reassociation, NaN
    and infinities kept) and with its machine code cached on disk where the package directory is writable.

    Raises :class:`~socialaff_sim.errors.ConfigError` naming the setting and the extra when numba is missing."""
    require("numba")
    import numba  # the optional extra: imported here so that the package works without it

    return numba.njit(cache=True, fastmath=False, nogil=True)(function)


_ONCE: dict[str, Any] = {}
"""What :func:`once` built, by name (this process's)."""


def once(name: str, build: Callable[[], T], warm: Callable[[T], object] | None = None) -> T:
    """The compiled objects ``build()`` makes (kernels, a dict of them, a module), made and warmed up
    (``warm(built)``: each kernel called on a tiny input of the argument types its caller passes, so that the JIT's
    cost — a compilation, or numba's cache load — is paid now, not at a stream's first frame) at the first call in the
    process with this ``name``, then returned as they are. ``name`` is unique per kernel module (its module's name).

    The first call raises :func:`require`'s :class:`~socialaff_sim.errors.ConfigError` when numba is missing, before
    ``build``; later calls return the built objects without checking again (one dict look-up: some callers ask at
    every frame). What ``build`` or ``warm`` raises propagates and nothing is kept (the next call builds again). Not
    thread-safe, and not needed to be: the reactor runs in one thread; two threads' first calls could both build (the
    last one's objects are kept, each equivalent)."""
    try:
        return _ONCE[name]
    except KeyError:
        pass
    require("numba")
    built = build()
    if warm is not None:
        warm(built)
    _ONCE[name] = built
    return built
