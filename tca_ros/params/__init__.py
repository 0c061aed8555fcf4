"""Parameter files and stores: the file I/O above the physics of tca_ros.model.

files.py reads and writes the ROS params files that describe a TCA, config_search.py
finds the shipped ones (``config/*.yaml``), thread_presets.py reads the thread
presets (``config/threads/threads.yaml``) and row_cache.py keeps the conical rod
table's rows on disk. Importing this package installs that disk cache
(row_cache.install_disk_cache), so every program that reads a params file reuses the
rows a previous run solved.
"""
from tca_ros.params.row_cache import install_disk_cache

install_disk_cache()
