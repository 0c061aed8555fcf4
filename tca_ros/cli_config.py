"""`tca_sim config new`: write a params file from what a maker knows of a muscle."""
import argparse


def add_parser(subparsers):
    """Register the ``config`` command (and its ``new`` subcommand) on ``subparsers``."""
    fmt = argparse.ArgumentDefaultsHelpFormatter
    sp = subparsers.add_parser('config', formatter_class=fmt,
                               help="describe a user's own muscle as a params file")
    sub = sp.add_subparsers(dest='config_command', required=True)
    return sub
