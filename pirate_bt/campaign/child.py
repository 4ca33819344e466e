"""The per-case child process: ``python -m pirate_bt.campaign.child``.

Reads one JSON request ``{"target", "case", "trace_dir"}`` on standard input,
calls the target (``module:function``, default :func:`run_case`) and writes the
record as one JSON line on standard output. The engine starts one per case, in
its own session, so a crash, a hang or a runaway simulation stays in it.
"""

from __future__ import annotations

import importlib
import json
import sys

__all__ = ["main"]


def main() -> int:
    request = json.loads(sys.stdin.read())
    module, _, name = str(request["target"]).partition(":")
    func = getattr(importlib.import_module(module), name)
    record = func(request["case"], request.get("trace_dir"))
    sys.stdout.write(json.dumps(record, allow_nan=False, default=str) + "\n")
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
