import pytest
from filterbank_cases import four_types


@pytest.fixture
def bank():
    return four_types()
