"""The paper's modal baseline: eigenvalues, the EMA route to E, gamma and c_d, ERA, H1.

* ``eigen``: clamped-free eigenvalues (Table 2), with or without a tip body.
* ``ema``: eqs. (25)-(29) of Banks & Inman (1989) -- E from frequencies, damping
  coefficients from damping ratios by successive least squares (Table 4).
* ``era``: Eigensystem Realization Algorithm on free decays, stabilization diagrams.
* ``frf``: H1 from impact tests with force/exponential windows, rational-fraction fit.
* ``decay``: ERA on a recording -- free-decay segment, mixed sensors, bending-mode numbers.
* ``outputs``: the files of ``bayesbeam ema`` and ``bayesbeam era``.
"""

from bayesbeam.modal.decay import (
    RecordingModes,
    identify_modes,
)
from bayesbeam.modal.eigen import (
    clamped_free_betas,
    natural_frequencies_hz,
    tip_body_betas,
)
from bayesbeam.modal.ema import (
    EmaResult,
    ModalTable,
    damping_ratio_model,
    ema_from_table,
    read_modal_table,
    write_modal_table,
)
from bayesbeam.modal.era import (
    EraModes,
    StabilizationDiagram,
    era,
    plot_stabilization,
    stabilization,
)
from bayesbeam.modal.frf import (
    FrfEstimate,
    fit_rational_fraction,
    h1_estimate,
    modal_parameters,
)

__all__ = [
    "EmaResult",
    "EraModes",
    "FrfEstimate",
    "ModalTable",
    "RecordingModes",
    "StabilizationDiagram",
    "clamped_free_betas",
    "damping_ratio_model",
    "ema_from_table",
    "era",
    "fit_rational_fraction",
    "h1_estimate",
    "identify_modes",
    "modal_parameters",
    "natural_frequencies_hz",
    "plot_stabilization",
    "read_modal_table",
    "stabilization",
    "tip_body_betas",
    "write_modal_table",
]
