"""Build BehaviorTree.CPP's ticker (``tick.cpp``) once, into a cache keyed by its inputs.

The same way as the test suite's BT.CPP port checker (``tests/btcpp_checker/build.py``,
whose functions this imports): ``tick.cpp`` is compiled against the BehaviorTree.CPP
headers of the ``behaviortreepy`` source distribution and linked against the
BehaviorTree.CPP that the installed ``behaviortreepy`` wheel carries (BT.CPP 4.8, built
as a release build), so nothing of BT.CPP is recompiled: one C++ file, about 10 s on the
2-core machine, once. ``tick.cpp`` itself is built with ``-O2 -DNDEBUG``. The result is
cached under ``benchmarks/btcpp_tick/build/<hash>/`` (ignored by git), keyed by the
source, the extension and the source distribution; the headers are shared with the
checker's cache.

Run it by hand with ``.venv/bin/python benchmarks/btcpp_tick/build.py`` (prints the path).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
from pathlib import Path
from types import ModuleType

HERE = Path(__file__).resolve().parent
CACHE = HERE / "build"
SOURCE = HERE / "tick.cpp"
CHECKER = HERE.parent.parent / "tests" / "btcpp_checker" / "build.py"


class Unavailable(Exception):
    """The ticker cannot be built here (no compiler, no bindings, no sources)."""


def _checker() -> ModuleType:
    if not CHECKER.is_file():
        raise Unavailable(f"{CHECKER} is missing (it finds BT.CPP's headers and library)")
    spec = importlib.util.spec_from_file_location("btcpp_checker_build", CHECKER)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def build_ticker() -> Path:
    """The ticker executable, built if the cache has none for these inputs.

    Raises:
        Unavailable: no C++ compiler, no ``behaviortreepy``, no BT.CPP sources, or the
            compiler failed (the message ends with its last error lines).
    """
    compiler = shutil.which("g++") or shutil.which("c++")
    if compiler is None:
        raise Unavailable("no C++ compiler (g++)")
    checker = _checker()
    try:
        extension = checker._extension()
        sdist = checker._sdist()
    except checker.Unavailable as exc:
        raise Unavailable(str(exc)) from None
    binary = checker.cached_binary(CACHE, "btcpp_tick", SOURCE, extension, sdist)
    if binary.is_file():
        return binary
    binary.parent.mkdir(parents=True, exist_ok=True)
    scratch = binary.parent / f"btcpp_tick.{os.getpid()}.tmp"
    command = checker.compile_command(
        compiler, SOURCE, scratch, extension, sdist, ["-O2", "-DNDEBUG"]
    )
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    except subprocess.TimeoutExpired:
        raise Unavailable("compiling tick.cpp took over 10 minutes") from None
    if result.returncode != 0:
        scratch.unlink(missing_ok=True)
        last = " ".join(result.stderr.strip().splitlines()[-3:])
        raise Unavailable(f"tick.cpp does not build: {last[-600:]}")
    os.replace(scratch, binary)  # a concurrent build sees a whole binary or none
    return binary


if __name__ == "__main__":
    print(build_ticker())
