"""The command line: one module per ``vo-reference`` command, parsing and printing only; nothing imports this package."""
