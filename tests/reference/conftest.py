"""The reference recordings' session fixture, for the tests in this folder."""
from tests.reference.recordings import reference_recordings  # noqa: F401 (a fixture)
