"""What every `tca_sim` command module shares: the parser, the input error, the config check.

Kept apart from cli/main.py so the command modules (cli_calibrate, ...) that cli/main.py
registers need not import cli/main.py back.
"""
import argparse
import math
import os
import signal
import subprocess
import sys

import numpy as np

from tca_ros.params.config_search import resolve_config
from tca_ros.params.files import load_params
from tca_ros.records.data import clip, NUMBER

MAX_CONFIG_BYTES = 1 << 20  # a params file is a few kB; refuse to parse megabytes of YAML
#: Exit statuses: ok; a solver or fit failed; bad input; the run ended on a physical
#: event (the thread broke or melted) after writing the rows simulated before it.
EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_EVENT = 0, 1, 2, 3
MESSAGE_CHARS = 400  # an error line is cut here: never echo megabytes of input
MAX_OUTPUT_SAMPLES = 1_000_000  # simulate / diagnose samples: about 50 MB of arrays


class InputError(ValueError):
    """Bad command-line input; the message is one line."""


CONFIG_HELP = 'params file (path or shipped name: free_stroke, self_coiled, conical)'
MODEL_HELP = "kinetostatic model (default: the config's model)"


def add_config_options(sp, default='free_stroke', config_help=CONFIG_HELP, model=True,
                       model_help=MODEL_HELP, required=False):
    """Add --config (a params file or shipped name) and, with ``model``, --model to ``sp``."""
    from tca_ros.model.params_schema import MODELS
    kind = {'required': True} if required else {'default': default}
    sp.add_argument('--config', help=config_help, **kind)
    if model:
        sp.add_argument('--model', choices=MODELS, default=None, help=model_help)


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


def params_from_args(args):
    """Return the params of ``--config`` with ``--model`` and ``--rig`` when given."""
    overrides = {'model': args.model} if getattr(args, 'model', None) else {}
    if getattr(args, 'rig', None):
        overrides['rig.mode'] = args.rig
    return load_params(checked_config(args.config), **overrides)


def check_finite(columns, where, unit):
    """Raise ValueError (exit 1) naming the first non-finite value of ``columns``.

    ``columns`` maps a name to an array, ``where`` holds the row coordinates in
    ``unit``. Output that is not finite is never printed.
    """
    for name, values in columns.items():
        values = np.asarray(values, dtype=float)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise ValueError(f'the model left its valid range: {name} is {values[bad[0]]!r} '
                             f'at {where[bad[0]]:g} {unit}')


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


def warn(command, text, stream=None):
    """Write ``tca_sim COMMAND: warning: text`` as one line on stderr."""
    line = ' '.join(str(text).split())
    (stream or sys.stderr).write(f'tca_sim {command}: warning: {clip(line, MESSAGE_CHARS)}\n')


def warn_reading(command, records):
    """Warn what reading each record decided that its file does not say (Record.reading)."""
    for record in records:
        for note in record.reading:
            warn(command, f'{record.source}: {note}')


class HelpFormatter(argparse.HelpFormatter):
    """Help with at most one default per option, and examples kept as written.

    argparse's ArgumentDefaultsHelpFormatter appends ``(default: X)`` to every
    option, also after a help text that already says its default, and prints
    ``(default: None)``, ``(default: )`` and ``(default: False)`` for options whose
    default means "not given". Here a default is appended only when it is a value
    and the help does not already name one. In a description or epilog, indented
    lines (example commands) are kept as written; the other lines are filled.
    """

    def _fill_text(self, text, width, indent):
        out, prose = [], []
        for line in text.splitlines() + ['']:
            if line.strip() and not line.startswith(' '):
                prose.append(line)
                continue
            if prose:
                out.append(super()._fill_text(' '.join(prose), width, indent))
                prose = []
            out.append(indent + line if line.strip() else '')
        return '\n'.join(out[:-1])

    def _get_help_string(self, action):
        text = action.help or ''
        default = action.default
        if ('default' in text.lower() or default in (None, '', False, argparse.SUPPRESS)
                or not action.option_strings or isinstance(default, bool)):
            return text
        return f'{text} (default: %(default)s)'


class CliParser(argparse.ArgumentParser):
    """ArgumentParser of `tca_sim` and its subcommands: exact flags, one-line errors.

    No abbreviations (``--mas`` is not ``--mass``); a usage error is one line
    ``tca_sim SUBCOMMAND: error: ...`` naming the subcommand that refused it, exit
    status 2; a missing subcommand is named with its choices.
    """

    def __init__(self, *args, **kwargs):
        kwargs['allow_abbrev'] = False
        kwargs['formatter_class'] = HelpFormatter  # every subcommand's help alike
        super().__init__(*args, **kwargs)
        self._commands = None

    def add_subparsers(self, **kwargs):
        """Add subcommands (not argparse-required: a missing one is named in words)."""
        kwargs['required'] = False
        self._commands = super().add_subparsers(**kwargs)
        return self._commands

    def parse_known_args(self, args=None, namespace=None):
        """Parse; refuse unknown arguments here, where the subcommand is known."""
        commands = self._commands
        args = sys.argv[1:] if args is None else list(args)
        if commands is None:  # a flag that is not ours is named before any other problem
            unknown = []
            for arg in args:
                if arg == '--':
                    break
                if (arg.startswith('-') and arg != '-'
                        and not self._negative_number_matcher.match(arg)
                        and arg.split('=', 1)[0] not in self._option_string_actions):
                    unknown.append(arg)
            if unknown:
                self.error(f'unrecognized arguments: {" ".join(unknown)}')
        namespace, extras = super().parse_known_args(args, namespace)
        if commands is None and extras:
            self.error(f'unrecognized arguments: {" ".join(extras)}')
        if commands is not None and getattr(namespace, commands.dest, None) is None:
            helps = {a.dest: a.help for a in commands._choices_actions}
            if len(helps) <= 3:
                choices = '; '.join(f'{name} ({text})' for name, text in helps.items())
            else:
                choices = ', '.join(helps)
            what = 'subcommand' if ' ' in self.prog else 'command'
            self.error(f'missing the {what}: '
                       f'choose one of {choices}; `{self.prog} NAME --help` describes each')
        return namespace, extras

    def error(self, message):
        """Print ``prog: error: message`` on one line (cut) and exit with status 2."""
        line = ' '.join(str(message).split())
        self.exit(EXIT_BAD_INPUT, f'{self.prog}: error: {clip(line, MESSAGE_CHARS)}\n')


def package_version():
    """Return the version of tca_ros: its package metadata, else package.xml's."""
    from importlib import metadata
    try:
        return metadata.version('tca_ros')
    except metadata.PackageNotFoundError:  # run from a source tree that is not installed
        import re
        root = os.path.dirname(os.path.dirname(os.path.dirname(__file__)))
        xml = os.path.join(root, 'package.xml')
        try:
            with open(xml, encoding='utf-8') as fh:
                found = re.search(r'<version>([^<]+)</version>', fh.read())
        except OSError:
            found = None
        return found.group(1) if found else 'unknown'
