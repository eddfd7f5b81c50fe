"""One module per ``gantry`` subcommand: HELP, add_arguments(parser), run(args) -> int."""
