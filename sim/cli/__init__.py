"""The command line: the only code that parses arguments, prints tables and names files."""
