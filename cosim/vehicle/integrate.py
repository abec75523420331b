"""Fixed-step fourth-order Runge-Kutta on a list of floats.

The plants are small (6 or 12 states) and are stepped thousands of times per
simulated second, so plain Python floats in lists beat tiny numpy arrays here.
"""

from __future__ import annotations

from collections.abc import Callable

Derivative = Callable[[list[float]], list[float]]


def rk4_step(f: Derivative, s: list[float], h: float) -> list[float]:
    """One classical RK4 step of ds/dt = f(s) (inputs held) of length h."""
    half = 0.5 * h
    k1 = f(s)
    # zip without strict=: the lengths match by construction and strict costs ~20 %
    k2 = f([a + half * b for a, b in zip(s, k1)])  # noqa: B905
    k3 = f([a + half * b for a, b in zip(s, k2)])  # noqa: B905
    k4 = f([a + h * b for a, b in zip(s, k3)])  # noqa: B905
    sixth = h / 6.0
    return [
        a + sixth * (b + 2.0 * (c + d) + e)
        for a, b, c, d, e in zip(s, k1, k2, k3, k4)  # noqa: B905
    ]
