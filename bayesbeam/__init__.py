"""bayesbeam: which damping mechanism is in this beam, how sure are we, and what is missing?

After Banks & Inman (1989), "On damping mechanisms in beams". From Python: :func:`check`,
:func:`fit`, :func:`compare`, :func:`diagnose` and :func:`load` (:mod:`bayesbeam.api`, docs/python.md).
"""
from bayesbeam.api import Check, Comparison, Diagnosis, Fit, check, compare, diagnose, fit, load
from bayesbeam.io import RecordingError, load_recording, write_recording
from bayesbeam.model import BeamModel

__version__ = "0.1.0"
__all__ = ["BeamModel", "Check", "Comparison", "Diagnosis", "Fit", "RecordingError", "__version__", "check",
           "compare", "diagnose", "fit", "load", "load_recording", "write_recording"]
