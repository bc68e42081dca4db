"""The command lines' parser: a mistake in one line, like every other bad input (exit 2)."""
import argparse


class Parser(argparse.ArgumentParser):
    """Command-line mistakes in one line, like every other bad input (exit code 2)."""

    def error(self, message):
        self.exit(2, f"error: {self.prog}: {message} (see --help)\n")
