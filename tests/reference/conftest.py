"""The reference recordings' fixture (built once per test run), for the tests in this folder."""
from tests.reference.recordings import reference_recordings  # noqa: F401 (a fixture)
