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


#: Test files that start ROS nodes: one xdist worker runs them all, one at a time, so
#: two nodes of different tests never share a DDS domain at once.
ROS_TEST_PREFIXES = ('test_node', 'test_install_layout')


def pytest_collection_modifyitems(config, items):
    """Put every ROS test in one xdist group (``--dist loadgroup`` in the Makefile)."""
    for item in items:
        if item.path.name.startswith(ROS_TEST_PREFIXES):
            item.add_marker(pytest.mark.xdist_group('ros'))
