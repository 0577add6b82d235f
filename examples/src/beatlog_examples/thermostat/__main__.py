"""``python -m beatlog_examples.thermostat -o thermostat.beatlog``: record the thermostat."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from beatlog.errors import LogExistsError
from beatlog_examples.thermostat.controller import record


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Record the thermostat in a simulated room.")
    parser.add_argument("-o", "--output", type=Path, required=True, help="the .beatlog to write")
    parser.add_argument("--hours", type=float, default=2.0, help="of room time (default 2)")
    parser.add_argument("--seed", type=int, default=None, help="of beatlog's random numbers")
    args = parser.parse_args(argv)
    try:
        print(f"wrote {record(args.output, hours=args.hours, seed=args.seed)}")
    except LogExistsError:
        parser.exit(2, f"{args.output}: exists already; give a new file name\n")


if __name__ == "__main__":
    main()
