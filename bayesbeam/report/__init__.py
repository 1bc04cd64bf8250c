"""Figures, the self-contained HTML reports and the output files of fit, compare and diagnose.

Figures are drawn for files, with matplotlib's Agg backend (no window, no display needed), except
inside a Jupyter kernel, whose own inline backend shows the figures the Python API returns.
"""
import sys

import matplotlib

if "ipykernel" not in sys.modules:
    matplotlib.use("Agg")
