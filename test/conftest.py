"""Shared fixtures of the tca_ros test suite."""
import pytest

from tca_ros.model.params import load_params


@pytest.fixture(scope='session')
def free_stroke():
    """Return the free-stroke TCA parameters (config/free_stroke.yaml)."""
    return load_params('free_stroke')


@pytest.fixture(scope='session')
def self_coiled():
    """Return the self-coiled TCA parameters (config/self_coiled.yaml)."""
    return load_params('self_coiled')
