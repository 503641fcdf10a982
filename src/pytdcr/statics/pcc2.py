"""``pcc2``: the paper's PCC model with each subsegment's moment balance taken at its midpoint.

Same unknowns, kinematics, tendon, friction and weight rules as ``pcc``
(MODEL.md); only where and in which frame the balance is written changes
(MODEL.md, appendix A): about the arc's midpoint p_m = d(beta, gamma; l/2),
in the midpoint's cross-section frame R_m = Exp((l/2)[-gamma, beta, 0])
Rz(eps/2), where the bending moment is EI Rz(-eps/2)[-gamma, beta, 0] and the
torsion GJ eps/l. The base balance is the left-point rule for the internal
moment along the subsegment, first order in the disk spacing; the midpoint
balance is the midpoint rule, second order (derivation and measured orders in
docs/models.md). The solver, the Jacobian machinery and the tip gradient are
``pcc``'s.
"""

from __future__ import annotations

from .kernels import pcc as K
from .pcc import PCCModel

__all__ = ["PCC2", "PCC2Model"]


class PCC2Model(PCCModel):
    """The registry's entry for ``pcc2`` (see the module docstring)."""

    name = "pcc2"
    description = "PCC with each subsegment balanced at its midpoint: second order in the disk spacing"
    balance = K.BALANCE_MIDPOINT


#: the registry's instance
PCC2 = PCC2Model()
