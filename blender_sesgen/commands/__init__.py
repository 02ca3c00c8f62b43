"""The command line: one module per ``sesgen`` command, parsing and printing only; nothing imports this package."""
