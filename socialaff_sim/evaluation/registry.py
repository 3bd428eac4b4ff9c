"""The registry of reaction-synthesis methods by name, as the evaluation and the CLI select them.

Registering a method
    ``register_method(name, factory)`` adds a factory (a picklable callable returning a fresh,
    unfitted :class:`~socialaff_sim.inference.protocol.ReactionMethod`, e.g. a module-level function
    or class) under ``name``; a factory with a ``preset`` keyword receives the run's preset name
    (``"default"`` or ``"paper"``). The built-in methods are registered here, where the evaluation
    can see every method from above: the baselines ``"hmm"``, ``"promp"``, ``"hold"``,
    ``"constvel"``, ``"ridge"`` and ``"gru"`` (:mod:`socialaff_sim.baselines`; ``"gru"`` needs the
    ``[neural]`` extra and fails with a :class:`~socialaff_sim.errors.ConfigError` naming it without torch), and the full model and its ablations ``"full"``,
    ``"full_online"``, ``"full_plan"`` (the default preset's synthesis without the switching regression,
    :mod:`socialaff_sim.inference.switching`), ``"full_noprimitive"`` (the default preset's ``full`` whose switching
    regression lacks the interaction primitive's family: ``FAMILIES``, the default before it, docs/design.md §8),
    ``"v1"`` and ``"v2"`` (:class:`~socialaff_sim.inference.methods.AffordanceMethod`).
    :func:`get_method` fails with an error listing the available names.
"""

from __future__ import annotations

from ..baselines.gru import GRUReaction
from ..baselines.hmm import MultiLevelHMM
from ..baselines.promp import InteractionProMP
from ..baselines.ridge import RidgeReaction
from ..baselines.simple import ConstantVelocity, HoldPose
from ..errors import ConfigError, choices
from ..inference.methods import REGISTERED_CHAINS, AffordanceMethod
from ..inference.protocol import MethodFactory, ReactionMethod
from ..inference.switching import FAMILIES, SwitchingConfig
from ..inference.synthesis import SynthesisConfig

__all__ = ["METHODS", "available_methods", "get_method", "register_method"]


def _hmm() -> ReactionMethod:
    return MultiLevelHMM()


def _promp() -> ReactionMethod:
    return InteractionProMP()


def _hold() -> ReactionMethod:
    return HoldPose()


def _constvel() -> ReactionMethod:
    return ConstantVelocity()


def _ridge() -> ReactionMethod:
    return RidgeReaction()


def _gru() -> ReactionMethod:
    # raises ConfigError naming the [neural] extra when torch is absent
    return GRUReaction()


def _full(preset: str = "default") -> AffordanceMethod:
    return AffordanceMethod.from_preset("full", preset, chains=REGISTERED_CHAINS)


def _v1(preset: str = "default") -> AffordanceMethod:
    return AffordanceMethod.from_preset("v1", preset, chains=REGISTERED_CHAINS)


def _v2(preset: str = "default") -> AffordanceMethod:
    return AffordanceMethod.from_preset("v2", preset, chains=REGISTERED_CHAINS)


def _full_plan(preset: str = "default") -> AffordanceMethod:
    # the ablation: Algorithm 2's synthesis without the switching regression on top (as "full" under the paper preset)
    return AffordanceMethod.from_preset("full", preset, chains=REGISTERED_CHAINS, reaction=None, name="full_plan")


def _full_noprimitive(preset: str = "default") -> AffordanceMethod:
    # the ablation: the switching regression without the interaction primitive's family (the paper preset has no regression)
    reaction = SwitchingConfig(families=FAMILIES) if preset == "default" else None
    return AffordanceMethod.from_preset("full", preset, chains=REGISTERED_CHAINS, reaction=reaction, name="full_noprimitive")


def _full_online() -> AffordanceMethod:
    cfg = SynthesisConfig()  # the paper's Algorithm 2 settings under every protocol
    return AffordanceMethod("full", synthesis=cfg, offline_synthesis=cfg, name="full_online")


METHODS: dict[str, MethodFactory] = {
    "hmm": _hmm,
    "promp": _promp,
    "hold": _hold,
    "constvel": _constvel,
    "ridge": _ridge,
    "gru": _gru,
    "full": _full,
    "full_online": _full_online,
    "full_plan": _full_plan,
    "full_noprimitive": _full_noprimitive,
    "v1": _v1,
    "v2": _v2,
}
"""Method factories by name. Add to it only through :func:`register_method`."""


def register_method(name: str, factory: MethodFactory, *, replace: bool = False) -> None:
    """Make ``factory`` available as method ``name`` (snake_case).

    Registering the same factory twice is harmless; another factory under a taken
    name needs ``replace=True``. The factory must be picklable (a module-level
    function or class, or a ``functools.partial`` of one) because the evaluation
    runs methods in worker processes.
    """
    if not isinstance(name, str) or not name.isidentifier() or name != name.lower():
        raise ConfigError(f"register_method: expected a lower-case identifier as name, found {name!r}")
    if not callable(factory):
        raise ConfigError(f"register_method({name!r}): expected a callable factory, found {type(factory).__name__}")
    old = METHODS.get(name)
    if old is not None and old is not factory and not replace:
        raise ConfigError(f"register_method: method {name!r} is already registered; pass replace=True to override it")
    METHODS[name] = factory


def available_methods() -> tuple[str, ...]:
    """Names of every registered method, sorted."""
    return tuple(sorted(METHODS))


def get_method(name: str) -> MethodFactory:
    """The factory registered under ``name``; the error lists the available methods."""
    try:
        return METHODS[name]
    except KeyError:
        raise ConfigError(
            f"unknown method {name!r}; available methods: {choices(sorted(METHODS))} "
            "(add your own with socialaff_sim.evaluation.register_method)"
        ) from None
