"""The check of every state a public function hands to the compiled kernels (issue: memory safety), and of a strategy."""

from __future__ import annotations

from .._validate import state_time, state_vector
from ..complements import ArticulatedComplement
from ..errors import ModelError


class StateChecks:
    """``_state``: a time and state vectors checked once at a public entry (mixed into :class:`~flexmb.system.System`).

    The kernels run without bounds checks; the public methods check here
    and call their private counterparts (``_kinematics``, ``_accelerations``,
    ``_state_rate``, ...), which the integrators call directly with the
    states they step.
    """

    def _refuse_articulated(self, strategy):
        """Refuse the 'articulated' strategy for a model with constraint elements, naming them."""
        if self.constraints.elements and isinstance(strategy, ArticulatedComplement):
            names = ", ".join(repr(e.name) for e in self.constraints.elements)
            raise ModelError(
                f"complement='articulated' cannot take constraint elements ({names}): the loop kernel closes "
                "only cut-joint and driver rows; use 'auto' (which takes the dense complement for such a model) "
                "or 'svd'")

    def _state(self, where, t, **vectors):
        """``t`` and the named vectors checked for the compiled kernels (:func:`~flexmb._validate.state_vector`).

        ``x`` has the model's nq coordinates, ``xd`` and ``xdd`` its n
        speeds, ``y`` is ``(x, xd)`` (nq + n; ``y_long``: at least nq + n,
        the rest not read; :mod:`flexmb.state_layout`).
        Returns ``t`` and the vectors in the order given.

        Raises
        ------
        ModelError
            Naming ``where``, the argument and what is wrong with it.
        """
        sizes = {"y": self.layout.size, "x": self.n_coords}
        out = [state_time(where, t)]
        for what, value in vectors.items():
            if what == "y_long":
                out.append(state_vector(where, "y", value, self.layout.size, at_least=True))
            else:
                out.append(state_vector(where, what, value, sizes.get(what, self.n_speeds)))
        return out
