"""Build the Groot2 oracle once, into a cache keyed by its inputs: BT.CPP's client and server.

Two programs, both from BehaviorTree.CPP's own sources (the ``behaviortreepy``
source distribution, found as ``tests/btcpp_checker/build.py`` finds it):

``groot2_client`` (``client.cpp``)
    a Groot2 client on BT.CPP's protocol header (``groot2_protocol.h``) and cppzmq,
    linked against the system's libzmq (Debian: ``libzmq3-dev cppzmq-dev``; ``make
    test`` installs them where it may).
``groot2_reference`` (``reference.cpp``)
    BT.CPP's ``Groot2Publisher`` and ``TreeObserver`` serving a tree loaded from
    pirate_bt's XML; linked against the BT.CPP inside the installed wheel (which
    carries the publisher and its own libzmq), plus ``bt_observer.cpp`` from the
    sources, which the wheel does not carry.

Nothing else of BT.CPP is recompiled: about 30 s on a busy two-core machine, once;
cached under ``tests/groot2_oracle/build/<hash>/``. Run by hand with
``python tests/groot2_oracle/build.py`` (prints both paths).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import shutil
import subprocess
import sysconfig
import tarfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from types import ModuleType

HERE = Path(__file__).resolve().parent
CACHE = HERE / "build"
CHECKER = HERE.parent / "btcpp_checker" / "build.py"
SOURCES = (HERE / "client.cpp", HERE / "reference.cpp")
_ZMQ_HEADERS = ("/usr/include/zmq.h", "/usr/include/zmq.hpp", "/usr/include/zmq_addon.hpp")


def _checker() -> ModuleType:
    spec = importlib.util.spec_from_file_location("btcpp_checker_build", CHECKER)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


checker = _checker()
Unavailable = checker.Unavailable


def _observer_source(sdist: Path, into: Path) -> Path:
    """BT.CPP's ``src/loggers/bt_observer.cpp`` from the source distribution."""
    target = into / "bt_observer.cpp"
    if target.is_file():
        return target
    into.mkdir(parents=True, exist_ok=True)
    with tarfile.open(sdist) as archive:
        member = next(
            (m for m in archive.getmembers() if m.name.endswith("src/loggers/bt_observer.cpp")),
            None,
        )
        if member is None:
            raise Unavailable(f"{sdist.name} has no src/loggers/bt_observer.cpp")
        data = archive.extractfile(member)
        assert data is not None
        scratch = into / f"bt_observer.{os.getpid()}.tmp"
        scratch.write_bytes(data.read())
    os.replace(scratch, target)
    return target


def _compile(command: list[str], target: Path) -> None:
    scratch = target.with_name(f"{target.name}.{os.getpid()}.tmp")
    result = subprocess.run([*command, "-o", str(scratch)], capture_output=True, text=True)
    if result.returncode != 0:
        raise Unavailable(f"{target.name} does not build: {result.stderr[-2000:]}")
    os.replace(scratch, target)  # other test processes see a whole binary or none


def build_oracle() -> tuple[Path, Path]:
    """``(client, reference)``, built if the cache has none for these inputs.

    Raises:
        Unavailable: no C++ compiler, no libzmq/cppzmq headers, no bindings or sources.
    """
    compiler = shutil.which("g++") or shutil.which("c++")
    if compiler is None:
        raise Unavailable("no C++ compiler (g++)")
    missing = [h for h in _ZMQ_HEADERS if not Path(h).is_file()]
    if missing:
        raise Unavailable(
            f"{', '.join(missing)} missing: install libzmq3-dev and cppzmq-dev"
            " (make test does, as root)"
        )
    extension = checker._extension()
    sdist = checker._sdist()
    digest = hashlib.sha256()
    for part in (*SOURCES, extension, sdist, *map(Path, _ZMQ_HEADERS)):
        digest.update(hashlib.sha256(part.read_bytes()).digest())
    target_dir = CACHE / digest.hexdigest()[:16]
    client, reference = target_dir / "groot2_client", target_dir / "groot2_reference"
    if client.is_file() and reference.is_file():
        return client, reference
    target_dir.mkdir(parents=True, exist_ok=True)
    include, tinyxml = checker._headers(sdist, checker.CACHE / "headers" / sdist.stem)
    observer = _observer_source(sdist, CACHE / "sources" / sdist.stem)
    libs = extension.parent.parent / "behaviortreepy.libs"
    libdir = sysconfig.get_config_var("LIBDIR")
    abi = f"-D_GLIBCXX_USE_CXX11_ABI={1 if checker._uses_new_abi(extension) else 0}"
    jobs = []
    if not client.is_file():
        jobs.append(
            (
                [compiler, "-std=c++17", "-O0", f"-I{include}", str(SOURCES[0]), "-lzmq"],
                client,
            )
        )
    if not reference.is_file():
        jobs.append(
            (
                [
                    compiler,
                    "-std=c++17",
                    "-O0",
                    "-pthread",
                    abi,
                    f"-I{include}",
                    f"-I{tinyxml}",
                    str(SOURCES[1]),
                    str(observer),
                    str(extension),
                    f"-Wl,-rpath,{extension.parent}",
                    f"-Wl,-rpath-link,{libs}",
                    f"-L{libdir}",
                    f"-lpython{sysconfig.get_config_var('LDVERSION')}",
                    f"-Wl,-rpath,{libdir}",
                    "-Wl,--allow-shlib-undefined",
                ],
                reference,
            )
        )
    with ThreadPoolExecutor(max_workers=2) as pool:
        for done in [pool.submit(_compile, command, target) for command, target in jobs]:
            done.result()
    return client, reference


if __name__ == "__main__":
    for path in build_oracle():
        print(path)
