"""What each ``# pragma: no mutate`` hides: its line's mutants, run without the pragma.

A pragma hides every mutant of its line, not only the equivalent one it was written
for. This script copies the committed tree (``git archive HEAD``) to a scratch folder,
strips the pragmas of the ``[tool.mutmut]`` modules, runs mutmut on the functions that
had one (at most ``--children`` test processes), and prints, for each pragma line, its
mutants and what the tests did to them. A survivor must be an equivalent mutant that
docs/testing.md lists; anything else must say ``killed``.
"""

from __future__ import annotations

import argparse
import ast
import io
import json
import re
import subprocess
import sys
import tarfile
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PRAGMA = re.compile(r"\s*#\s*pragma:\s*no mutate\b.*$")
STATUS = {1: "killed", 3: "killed", 0: "survived", 33: "no tests", 34: "skipped", None: "not run"}


def enclosing(tree: ast.Module, line: int) -> str | None:
    """mutmut's mangled name of the function around ``line`` (``x_f`` or ``xǁClassǁf``)."""
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.lineno <= line <= (node.end_lineno or 0):
            return f"x_{node.name}"
        if isinstance(node, ast.ClassDef):
            for item in node.body:
                if isinstance(item, ast.FunctionDef) and item.lineno <= line <= (
                    item.end_lineno or 0
                ):
                    return f"xǁ{node.name}ǁ{item.name}"
    return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--children", type=int, default=2)
    args = parser.parse_args(argv)
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mutmut"]
    modules: list[str] = config["only_mutate"]
    with tempfile.TemporaryDirectory(prefix="pirate-pragmas-") as tmp:
        base = Path(tmp)
        archive = subprocess.run(
            ["git", "archive", "HEAD"], cwd=ROOT, capture_output=True, check=True
        ).stdout
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            # our own HEAD; filter="data" where the Python has it (3.11.4 and later)
            if hasattr(tarfile, "data_filter"):
                tar.extractall(base, filter="data")
            else:
                tar.extractall(base)
        lines: dict[str, list[tuple[int, str]]] = {}
        patterns: set[str] = set()
        for module in modules:
            path = base / module
            text = path.read_text().splitlines()
            tree = ast.parse("\n".join(text))
            dotted = module.removesuffix(".py").replace("/", ".")
            for number, line in enumerate(text, 1):
                if PRAGMA.search(line):
                    stripped = PRAGMA.sub("", line)
                    text[number - 1] = stripped
                    lines.setdefault(module, []).append((number, stripped.strip()))
                    function = enclosing(tree, number)
                    if function is not None:
                        patterns.add(f"{dotted}.{function}__mutmut_*")
            path.write_text("\n".join(text) + "\n")
        mutmut = str(Path(sys.executable).with_name("mutmut"))
        subprocess.run([mutmut, "run", "--max-children", str(args.children), *sorted(patterns)],
                       cwd=base, check=False)  # fmt: skip
        for module, found in lines.items():
            meta = json.loads((base / "mutants" / f"{module}.meta").read_text())
            codes = meta["exit_code_by_key"]
            print(f"\n== {module}")
            for number, code in found:
                print(f"  line {number}: {code}")
                for name, exit_code in sorted(codes.items()):
                    if not any(re.fullmatch(p.replace("*", ".*"), name) for p in patterns):
                        continue
                    diff = subprocess.run(
                        [mutmut, "show", name], cwd=base, capture_output=True, text=True
                    ).stdout
                    removed = [d[1:].strip() for d in diff.splitlines() if d.startswith("-")]
                    added = [d[1:].strip() for d in diff.splitlines() if d.startswith("+")]
                    if code in removed:
                        mutated = next((a for a in added if a), "")
                        status = STATUS.get(exit_code, "timeout" if exit_code else exit_code)
                        print(f"    {status:>9}  {mutated}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
