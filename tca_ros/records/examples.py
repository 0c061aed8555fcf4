"""The shipped example inputs: power profiles and synthetic records (tca_ros/data/examples/).

They are package data, so an installed package has them too. A shipped name is a
bare file name without directory, with or without ``.csv`` (``rec_1W_30g``,
``profile_steps.csv``); ``tca_sim simulate --input`` and ``--compare`` take either
a path or a shipped name, as ``--config`` does for params files. A path whose
directory does not exist is refused, never read as the shipped file of the same
name. Written by bench/make_examples.py; described in docs/records.md.
"""
import os

EXAMPLES_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                            'data', 'examples')


def shipped_examples(prefix=''):
    """Return the sorted names (no ``.csv``) of the shipped examples starting with ``prefix``."""
    if not os.path.isdir(EXAMPLES_DIR):
        return []
    return sorted(os.path.splitext(f)[0] for f in os.listdir(EXAMPLES_DIR)
                  if f.endswith('.csv') and f.startswith(prefix))


def resolve_example(name_or_path):
    """Return the file of ``name_or_path``: an existing path, else a shipped example, else None.

    A shipped name is bare (no directory part); ``rec_1W_30g`` and
    ``rec_1W_30g.csv`` name the same file.
    """
    if os.path.exists(name_or_path):
        return name_or_path
    if os.path.basename(name_or_path) != name_or_path or '\\' in name_or_path:
        return None
    stem = name_or_path[:-4] if name_or_path.endswith('.csv') else name_or_path
    path = os.path.join(EXAMPLES_DIR, stem + '.csv')
    return path if stem and os.path.isfile(path) else None
