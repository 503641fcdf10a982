"""The compiled (numba) kernels, one module per model and the solver they share; each has a thin Python
wrapper named alike one folder up:

- :mod:`~pytdcr.statics.kernels.pcc`: the PCC equations (``pcc`` and ``pcc2``), wrapped by
  :mod:`pytdcr.statics.pcc`;
- :mod:`~pytdcr.statics.kernels.sscr`: the subsegment Cosserat rod, wrapped by :mod:`pytdcr.statics.sscr`;
- :mod:`~pytdcr.statics.kernels.cosserat`: the smeared Cosserat rod, wrapped by :mod:`pytdcr.statics.cosserat`;
- :mod:`~pytdcr.statics.kernels.loading_path`: the quasi-Newton loading-path solver the PCC family and ``sscr``
  share, wrapped by :mod:`pytdcr.statics.compiled`; it solves every packed-model type the registry registers.

Functions here may be long (the house rule of 120 lines does not apply to kernel modules).
"""
