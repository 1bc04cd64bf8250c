"""What the acceptance tests share: the two worker processes their comparisons and diagnoses run on
(the suite's budget is two cores)."""
import pytest

from bayesbeam.executors import LocalExecutor


@pytest.fixture(scope="module")
def executor():
    """Two local worker processes, closed after the module's tests."""
    ex = LocalExecutor(2)
    yield ex
    ex.close()
