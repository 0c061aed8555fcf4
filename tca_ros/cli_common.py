"""What every `tca_sim` command module shares: the input error and the config check.

Kept apart from cli.py so the command modules (cli_calibrate, ...) that cli.py
registers need not import cli.py back.
"""
import argparse
import math
import os
import signal
import subprocess

from tca_ros.diagnosis.data import clip, NUMBER
from tca_ros.model.params import resolve_config

MAX_CONFIG_BYTES = 1 << 20  # a params file is a few kB; refuse to parse megabytes of YAML
EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2
MAX_OUTPUT_SAMPLES = 1_000_000  # simulate / diagnose samples: about 50 MB of arrays


class InputError(ValueError):
    """Bad command-line input; the message is one line."""


def checked_config(name_or_path, option='--config'):
    """Return the params file path of a config, refusing non-files and huge files."""
    path = resolve_config(name_or_path)
    if not os.path.isfile(path):
        raise InputError(f'{option} = {clip(name_or_path)!r}: not a regular file')
    size = os.path.getsize(path)
    if size > MAX_CONFIG_BYTES:
        raise InputError(f'{option} = {clip(name_or_path)!r}: {size} bytes; a params file '
                         f'is at most {MAX_CONFIG_BYTES} bytes')
    return path


def finite_float(text):
    """Return ``text`` as a finite float (argparse type); ASCII decimals only."""
    if not NUMBER.fullmatch(text.strip()):
        raise argparse.ArgumentTypeError(f'{clip(text)!r} is not a finite number '
                                         '(ASCII decimal, e.g. 2.5e-3)')
    value = float(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f'{clip(text)!r} is beyond +-1.8e308')
    return value


def stop_gracefully(proc, grace):
    """Stop a child process: SIGINT, then SIGKILL after ``grace`` s; return its exit code."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(grace)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


def count(text):
    """Return ``text`` as a positive int (argparse type of the work limits)."""
    if not text.strip().isascii() or not text.strip().isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f'{clip(text)!r} is not a positive integer')
    return int(text)
