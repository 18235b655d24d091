"""``python -m softbench ...``: softbench's command line with the peer methods registered.

The same command as the ``softbench`` binary (``run``, ``simulate``, ``merge``, ``slurm``,
``plot``, ``ledger``, ...; the same files, resume, ``--quick``, ``--jobs`` and sharding), run
by the same Rust code inside this Python process, so studies can name ``pbat-vbd`` or
``newton-xpbd`` beside softbench's own methods. Job scripts written by ``slurm`` call
``python -m softbench`` again.
"""

from __future__ import annotations

import sys

from . import _native


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    host = [sys.executable, "-m", "softbench"]
    try:
        return _native.cli(["softbench", *argv], host)
    except KeyboardInterrupt:
        # softbench's own handler has stopped the work at a safe point, written what was
        # done and said how to resume; Python raises its own once the call returns. Exit as
        # the binary does after SIGINT.
        return 130


if __name__ == "__main__":
    sys.exit(main())
