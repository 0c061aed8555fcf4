"""The tca_sim command line.

main.py holds the parser registry and dispatch, one module per subcommand,
common.py the shared argument helpers.
"""
