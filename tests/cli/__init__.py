"""Tests of the command line: parsers, help, one-line errors."""
