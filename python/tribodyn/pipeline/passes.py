"""The optional passes over the data of :func:`tribodyn.analyze` (docs/architecture.md, "Where a change goes").

An optional pass finds something more in the samples than the windows'
statistics (stick-slip: docs/method.md 6g). Each is one entry of
:data:`PASSES`: the option that asks for it, a function that builds its tap
before the main pass (it then sees every raw chunk of the route "stream" as
:func:`tribodyn.pipeline.routes.run` reads it; None when the route cannot feed
it) and a function that stores its result in the Results before ``settle``
(from the tap, or by reading the source again). Both take a
:class:`tribodyn.pipeline.routes.PassInputs`. A new pass is a module of
``pipeline/`` with those two functions, one entry here and its option.
"""

from __future__ import annotations

import dataclasses
from typing import Callable, Optional, Sequence, Tuple

from ..results import Results
from . import stickslip
from .plan import Plan
from .routes import PassInputs, Tap

__all__ = ["Pass", "PASSES", "taps", "store"]


@dataclasses.dataclass(frozen=True)
class Pass:
    """One optional pass over the data.

    Attributes
    ----------
    name : str
        The option that asks for it: a truth value of ``analyze``, a field of :class:`tribodyn.Plan`.
    tap : callable
        ``tap(inputs)``: its tap, built before the main pass; None when the route cannot feed it.
    store : callable
        ``store(inputs, tap, res)``: ``res`` with the pass's result (``tap`` None: read again).
    """

    name: str
    tap: Callable[[PassInputs], Optional[Tap]]
    store: Callable[[PassInputs, Optional[Tap], Results], Results]

    def asked(self, plan: Plan) -> bool:
        """Whether the plan asks for this pass."""
        return bool(getattr(plan, self.name))


#: The optional passes, in the order their results are stored.
PASSES: Tuple[Pass, ...] = (
    Pass("stick_slip", stickslip.reading_pass, stickslip.store),  # docs/method.md 6g
)


def taps(given: PassInputs) -> Tuple[Optional[Tap], ...]:
    """The tap of each of :data:`PASSES` (None: not asked for, or the route cannot feed it)."""
    return tuple(p.tap(given) if p.asked(given.plan) else None for p in PASSES)


def store(given: PassInputs, tapped: Sequence[Optional[Tap]], res: Results) -> Results:
    """``res`` with the result of each pass the plan asks for, from its tap (``tapped``, as :func:`taps` made
    them) or read again; before ``settle``, which keeps the headline it computes."""
    for p, tap in zip(PASSES, tapped):
        if p.asked(given.plan):
            res = p.store(given, tap, res)
    return res
