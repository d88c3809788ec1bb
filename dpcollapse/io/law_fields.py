"""The constitutive law's diagnostic fields (μ(I): the inertial number I = d|γ̇|/√(p/ρ_s)) as
DG0 output functions, shared by the models that export them."""

from __future__ import annotations

from dolfinx import fem

from dpcollapse import compat


class LawFields:
    """``law.diagnostic_fields(u, p, ε)`` as named DG0 functions on ``space`` with their
    compiled expressions; ``interpolated()`` evaluates them all for an output."""

    def __init__(self, law, u, p, epsilon, space):
        self._fields = {name: (fem.Function(space, name=name), compat.expression(expr, space))
                        for name, expr in law.diagnostic_fields(u, p, epsilon).items()}

    def __getitem__(self, name: str):
        """(function, expression) of the field ``name``."""
        return self._fields[name]

    def interpolated(self) -> list:
        """Every field evaluated at the current state, in the law's order."""
        for function, expression in self._fields.values():
            function.interpolate(expression)
        return [function for function, _ in self._fields.values()]
