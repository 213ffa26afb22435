"""What the recsys command lines share: bad input is one `error:` line and exit status 2."""

from __future__ import annotations

import argparse
import sys


class ArgumentParser(argparse.ArgumentParser):
    """`argparse.ArgumentParser` whose errors (a missing flag, `--users abc`) print one
    `error: ...` line, without the usage block, and exit with status 2."""

    def error(self, message: str):
        print(f"error: {message}", file=sys.stderr)
        sys.exit(2)
