"""bayesbeam: which damping mechanism is in this beam, how sure are we, and what is missing?

After Banks & Inman (1989), "On damping mechanisms in beams".
"""
from bayesbeam.io import RecordingError, load_recording, write_recording
from bayesbeam.model import BeamModel

__version__ = "0.1.0"
__all__ = ["BeamModel", "RecordingError", "load_recording", "write_recording", "__version__"]
