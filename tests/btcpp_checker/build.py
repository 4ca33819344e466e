"""Build the BT.CPP port checker (``checker.cpp``) once, into a cache keyed by its inputs.

The checker is compiled against the BehaviorTree.CPP headers of the
``behaviortreepy`` source distribution and linked against the BehaviorTree.CPP
that the installed ``behaviortreepy`` wheel already carries (its extension module
exports BT.CPP's symbols), so nothing of BT.CPP is recompiled: one C++ file,
about 5 s. The result is cached under ``tests/btcpp_checker/build/<hash>/``
(ignored by git), keyed by the checker's source, the headers and the extension.

Run it by hand with ``python tests/btcpp_checker/build.py`` (prints the path).

The source distribution is found at ``$PIRATE_BT_BTCPP_SDIST``, in the cache,
or at ``/tmp/btsrc/behaviortreepy-<version>.tar.gz``; failing those it is
fetched with ``pip download`` (the ordinary client) into the cache.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
CACHE = HERE / "build"
SOURCE = HERE / "checker.cpp"


class Unavailable(Exception):
    """The checker cannot be built here (no compiler, no bindings, no sources)."""


def _extension() -> Path:
    try:
        import behaviortreepy
    except ImportError:
        raise Unavailable(
            "behaviortreepy is not installed (pip install pirate-bt[btcpp])"
        ) from None
    found = sorted(Path(behaviortreepy.__file__).parent.glob("_behaviortreepy*.so"))
    if not found:
        raise Unavailable("behaviortreepy has no compiled extension to link against")
    return found[0]


def _sdist() -> Path:
    version = importlib.metadata.version("behaviortreepy")
    name = f"behaviortreepy-{version}.tar.gz"
    for candidate in (
        os.environ.get("PIRATE_BT_BTCPP_SDIST"),
        str(CACHE / name),
        f"/tmp/btsrc/{name}",
    ):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    CACHE.mkdir(parents=True, exist_ok=True)
    try:
        result = _pip_download(version)
    except subprocess.TimeoutExpired:
        raise Unavailable(f"fetching the {name} source distribution timed out") from None
    if result.returncode != 0 or not (CACHE / name).is_file():
        raise Unavailable(f"cannot fetch the {name} source distribution: {result.stderr[-300:]}")
    return CACHE / name


def _pip_download(version: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "download",
            "--no-deps",
            # the sdist of this one package: ':all:' also asks for its build dependencies
            # as sources, and Debian's pip 23.0 (a venv made with /usr/bin/python3) then
            # builds them and hung past the timeout, so every oracle test skipped
            "--no-binary",
            "behaviortreepy",
            "-d",
            str(CACHE),
            f"behaviortreepy=={version}",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )


def _extract(archive: tarfile.TarFile, into: Path, members: list[tarfile.TarInfo]) -> None:
    """``members`` of ``archive`` into ``into``, none of them outside it.

    Python 3.11.4 and later refuse such a member by ``filter="data"``; an older 3.11
    (Debian 12's 3.11.2) has no filter, so the names are checked here first.
    """
    if hasattr(tarfile, "data_filter"):
        archive.extractall(into, members=members, filter="data")
        return
    for member in members:
        name = Path(member.name)
        if name.is_absolute() or ".." in name.parts:
            raise Unavailable(f"the source distribution has a member outside it: {member.name!r}")
    archive.extractall(into, members=members)


def _headers(sdist: Path, into: Path) -> tuple[Path, Path]:
    """Extract BT.CPP's include/ and tinyxml2.h from the source distribution."""
    include, tinyxml = into / "include", into / "tinyxml2"
    if include.is_dir() and (tinyxml / "tinyxml2.h").is_file():
        return include, tinyxml
    into.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(dir=into.parent))
    with tarfile.open(sdist) as archive:
        members = [
            m
            for m in archive.getmembers()
            if (m.isfile() or m.isdir())
            and ("/BehaviorTree.CPP/include/" in m.name or m.name.endswith("tinyxml2/tinyxml2.h"))
        ]
        _extract(archive, staging, members)
    (staging / "include").mkdir(exist_ok=True)
    (staging / "tinyxml2").mkdir(exist_ok=True)
    for found in staging.glob("*/BehaviorTree.CPP/include/*"):
        shutil.move(str(found), staging / "include" / found.name)
    for found in staging.glob("*/BehaviorTree.CPP/3rdparty/tinyxml2/tinyxml2.h"):
        shutil.move(str(found), staging / "tinyxml2" / "tinyxml2.h")
    into.mkdir(parents=True, exist_ok=True)
    for part in ("include", "tinyxml2"):
        if not (into / part).exists():
            os.replace(staging / part, into / part)
    shutil.rmtree(staging, ignore_errors=True)
    return include, tinyxml


def _uses_new_abi(extension: Path) -> bool:
    # The wheel is built for manylinux2014 (old std::string ABI) or newer; follow it.
    return b"_ZN2BT19BehaviorTreeFactory18createTreeFromTextERKNSt7__cxx11" in (
        extension.read_bytes()
    )


def cached_binary(cache: Path, name: str, source: Path, extension: Path, sdist: Path) -> Path:
    """Where the binary ``name`` built from these inputs is cached: a folder of ``cache``
    named by a digest of the source, the extension and the source distribution."""
    digest = hashlib.sha256()
    for part in (source.read_bytes(), extension.read_bytes(), sdist.read_bytes()):
        digest.update(hashlib.sha256(part).digest())
    return cache / digest.hexdigest()[:16] / name


def compile_command(
    compiler: str, source: Path, output: Path, extension: Path, sdist: Path, flags: list[str]
) -> list[str]:
    """The g++ command that builds ``source`` into ``output`` against the wheel's BT.CPP.

    Compiled against the headers of the source distribution ``sdist`` (unpacked into
    this cache once) and linked against the BT.CPP inside the installed extension
    ``extension``, with the wheel's std::string ABI; ``flags`` are the optimisation
    flags (``-O0`` here, ``-O2 -DNDEBUG`` for the benchmarks' ticker).
    """
    include, tinyxml = _headers(sdist, CACHE / "headers" / sdist.stem)
    libs = extension.parent.parent / "behaviortreepy.libs"
    libdir = sysconfig.get_config_var("LIBDIR")
    return [
        compiler,
        "-std=c++17",
        *flags,
        f"-D_GLIBCXX_USE_CXX11_ABI={1 if _uses_new_abi(extension) else 0}",
        f"-I{include}",
        f"-I{tinyxml}",
        str(source),
        "-o",
        str(output),
        str(extension),
        f"-Wl,-rpath,{extension.parent}",
        f"-Wl,-rpath-link,{libs}",
        # the extension refers to Python's objects (never used here): link libpython
        f"-L{libdir}",
        f"-lpython{sysconfig.get_config_var('LDVERSION')}",
        f"-Wl,-rpath,{libdir}",
        "-Wl,--allow-shlib-undefined",
    ]


def build_checker() -> Path:
    """The checker executable, built if the cache has none for these inputs.

    Raises:
        Unavailable: no C++ compiler, bindings or sources.
    """
    compiler = shutil.which("g++") or shutil.which("c++")
    if compiler is None:
        raise Unavailable("no C++ compiler (g++)")
    extension = _extension()
    sdist = _sdist()
    binary = cached_binary(CACHE, "btcpp_checker", SOURCE, extension, sdist)
    if binary.is_file():
        return binary
    binary.parent.mkdir(parents=True, exist_ok=True)
    scratch = binary.parent / f"btcpp_checker.{os.getpid()}.tmp"
    command = compile_command(compiler, SOURCE, scratch, extension, sdist, ["-O0"])
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    if result.returncode != 0:
        raise Unavailable(f"the checker does not build: {result.stderr[-2000:]}")
    os.replace(scratch, binary)  # other test processes see a whole binary or none
    return binary


if __name__ == "__main__":
    print(build_checker())
