"""The lane-change policies by name: one registry, a duplicate name refused.

A policy class registers itself with one line, `@register("name")` above the class
(or `register("name", cls)`); from then on `[planner] policy = "name"` selects it in
a scenario file (`PLANNED`, the key's allowed values, reads the registry when it is
asked), the scenario key reference lists it, and `cosim compare` runs it as one more
variant. The built-in policies register when `cosim.driving` is imported.

A policy that flies planned manoeuvres (`needs_planner` true) is one `[planner]
policy` may name; one that hands the SV to SUMO (`needs_planner` false: the policy of
the SUMO-driven SV, controller "sumo") is chosen by the controller instead.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar, overload

from cosim.errors import InputError

P = TypeVar("P", bound=type)

_POLICIES: dict[str, type] = {}  # name -> policy class, in registration order


@overload
def register(name: str) -> Callable[[P], P]: ...
@overload
def register(name: str, cls: P) -> P: ...


def register(name: str, cls: Any = None) -> Any:
    """Register a policy class under `name` (as a decorator, or with the class); the
    class gets `name` as its `name` attribute. A name taken already is refused."""
    def add(policy: P) -> P:
        if not isinstance(name, str) or not name.isidentifier():
            raise ValueError(f"a policy name must be an identifier, not {name!r}")
        if name in _POLICIES:
            raise ValueError(f"policy {name!r} is registered already "
                             f"({_POLICIES[name].__module__}.{_POLICIES[name].__qualname__})")
        for attr in ("status", "update", "summary"):
            if not callable(getattr(policy, attr, None)):
                raise TypeError(f"policy {name!r}: {policy.__qualname__} has no {attr}()")
        policy.name = name
        _POLICIES[name] = policy
        return policy

    return add if cls is None else add(cls)


def unregister(name: str) -> None:
    """Remove a registered policy (tests that register one of their own)."""
    _POLICIES.pop(name, None)


def names(*, planned: bool | None = None) -> tuple[str, ...]:
    """The registered names in registration order (`planned`: only those that fly
    planned manoeuvres, or only those that do not)."""
    return tuple(n for n, c in _POLICIES.items()
                 if planned is None or bool(getattr(c, "needs_planner", True)) == planned)


def policy_class(name: str, source: str = "planner") -> type:
    """The class registered under `name`; an unknown name is an InputError."""
    try:
        return _POLICIES[name]
    except KeyError:
        raise InputError(source, "policy", name,
                         "one of " + ", ".join(repr(n) for n in names())) from None


class PlannedNames(Sequence[str]):
    """The names `[planner] policy` may take, read from the registry each time (a
    policy registered later is allowed too)."""

    def __len__(self) -> int:
        return len(names(planned=True))

    @overload
    def __getitem__(self, i: int) -> str: ...
    @overload
    def __getitem__(self, i: slice) -> Sequence[str]: ...

    def __getitem__(self, i: Any) -> Any:
        return names(planned=True)[i]

    def __iter__(self) -> Iterator[str]:
        return iter(names(planned=True))

    def __contains__(self, name: object) -> bool:
        return name in names(planned=True)

    def __repr__(self) -> str:
        return repr(names(planned=True))


PLANNED = PlannedNames()  # [planner] policy's allowed values


def prediction_of(name: str) -> Any:
    """The planner's prediction options the policy `name` needs (None: the defaults),
    for a planner built outside a run (`cosim plan`, the planner bench)."""
    return getattr(policy_class(name), "prediction", None)
