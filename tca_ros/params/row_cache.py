"""The conical rod table's rows on disk: solved once, read by every later process.

A row of tca_ros.model.conical_table costs a few seconds of rod solves. DiskRowStore
keeps each row as an ``.npz`` file in ``$TCA_ROS_CACHE`` (default
``~/.cache/tca_ros``), named by the table's key (a hash of the mechanical parameters
and the row format's version) and the row's index. An unreadable or foreign file is
solved again; a read-only directory only costs the solve next time.
"""
import os

import numpy as np

from tca_ros.model.conical_table import ConicalRow, use_row_store


def cache_dir():
    """Return the directory of cached rows: $TCA_ROS_CACHE or ~/.cache/tca_ros."""
    return os.environ.get('TCA_ROS_CACHE') or os.path.join(
        os.path.expanduser('~'), '.cache', 'tca_ros')


class DiskRowStore:
    """Rows of conical tables as npz files in ``directory`` (default: cache_dir() at use)."""

    def __init__(self, directory=None):
        self.directory = directory

    def path(self, key, index):
        """Return the file of row ``index`` of the table ``key``."""
        return os.path.join(self.directory or cache_dir(), f'conical_{key}_{index:03d}.npz')

    def load(self, key, index):
        """Return the stored ConicalRow, or None if absent or unreadable."""
        try:
            with np.load(self.path(key, index)) as data:
                return ConicalRow(**{k: (data[k] if data[k].ndim else float(data[k]))
                                     for k in data.files})
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def save(self, key, index, row):
        """Write ``row`` atomically (a partial file renamed); ignore a read-only cache."""
        path = self.path(key, index)
        try:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            partial = f'{path}.{os.getpid()}.tmp.npz'
            np.savez(partial, **row.__dict__)
            os.replace(partial, path)
        except OSError:
            pass  # a read-only cache only costs the rebuild next time


def install_disk_cache(directory=None):
    """Keep the rows of every conical table on disk from now on; return the store."""
    store = DiskRowStore(directory)
    use_row_store(store)
    return store
