"""``python -m pvrsim ARGS``: the pvrsim command line (``pvrsim --help``).

The same commands, options, messages and exit codes as the Rust binary.
``transport="processes"`` starts its worker processes this way
(``python -m pvrsim worker ...``), so a pip install needs no other program.
"""

from __future__ import annotations

import signal
import sys


def main() -> None:
    """Runs the command line with ``sys.argv`` and exits with its status."""
    from pvrsim import _native

    # The command runs in Rust: let Ctrl-C end the process as it ends the binary.
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    sys.exit(_native.cli_main(sys.argv[1:]))


if __name__ == "__main__":
    main()
