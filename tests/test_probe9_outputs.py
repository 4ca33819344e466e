"""An output never destroys an input, and a pipe or a device is no output (probe 9).

A hostile-input probe on 2026-11-29 found ``run tree.jsonl --trace tree.jsonl`` (and
the same through a symlink or a hard link, and ``mission r.jsonl --trace r.jsonl``)
replacing the tree or route with its trace, exit 0; ``survey --sim world.yaml -o
world.yaml`` replacing the pipe as it really is with the survey; a named pipe as
``--trace`` hanging the run before it began, and one as ``survey -o`` silently
replaced by a file; ``--trace`` on ``/dev/full`` failing only after the run.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.errors import InputError

ROOT = Path(__file__).resolve().parent.parent
TREE = "name: t\nroot: {type: wait, name: w, duration: 1 s}\n"


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "pirate_bt", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.mark.parametrize("how", ["same name", "symlink", "hard link"])
def test_a_trace_onto_the_tree_file_is_refused_and_the_tree_kept(tmp_path: Path, how: str) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text(TREE)
    trace = tmp_path / "tree.jsonl"
    if how == "same name":
        trace = tree = tree.rename(tmp_path / "tree.jsonl")
    elif how == "symlink":
        trace.symlink_to(tree)
    else:
        os.link(tree, trace)
    with pytest.raises(InputError, match=r"^trace: .*tree\.jsonl is the tree file; name another"):
        pirate_bt.simulate_tree(tree, trace=trace)
    assert tree.read_text() == TREE
    done = _cli("run", "--quiet", str(tree), "--trace", str(trace), cwd=tmp_path)
    assert done.returncode == 2, done
    assert done.stderr.count("\n") == 1 and "is the tree file" in done.stderr
    assert tree.read_text() == TREE


def test_a_trace_onto_the_route_or_its_network_is_refused(tmp_path: Path) -> None:
    network = tmp_path / "net.yaml"
    network.write_text((ROOT / "scenarios" / "bend-right.yaml").read_text())
    route = tmp_path / "r.jsonl"
    route.write_text("network net.yaml\nat the bend turn right\n")
    kept = route.read_text(), network.read_text()
    with pytest.raises(InputError, match="is the route file"):
        pirate_bt.simulate_mission(route, trace=route)
    with pytest.raises(InputError, match="is the network file"):
        pirate_bt.simulate_mission(pirate_bt.plan_route(route), trace=network)
    (tmp_path / "link.jsonl").symlink_to(network)
    done = _cli("mission", "-q", str(route), "--trace", "link.jsonl", cwd=tmp_path)
    assert done.returncode == 2 and "is the network file" in done.stderr, done
    assert (route.read_text(), network.read_text()) == kept


def test_a_survey_never_writes_over_the_pipe_it_surveys(tmp_path: Path) -> None:
    world = tmp_path / "world.yaml"
    world.write_text((ROOT / "scenarios" / "straight.yaml").read_text())
    before = world.read_text()
    with pytest.raises(InputError, match="is the simulated network file"):
        pirate_bt.survey(sim=world, output=world)
    assert world.read_text() == before


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
def test_a_named_pipe_is_no_trace_and_no_survey_output(tmp_path: Path) -> None:
    fifo = tmp_path / "f.jsonl"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="is not a regular file"):
        pirate_bt.simulate_tree("straight", params={"distance": "0.1 m"}, trace=fifo)
    out = tmp_path / "g.yaml"
    os.mkfifo(out)
    with pytest.raises(InputError, match="is not a regular file"):
        pirate_bt.survey(output=out)
    assert not out.is_file()  # still the pipe: not replaced by a file


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_device_is_no_trace_and_is_refused_before_the_run(tmp_path: Path) -> None:
    full = tmp_path / "full.jsonl"
    full.symlink_to("/dev/full")
    tree = tmp_path / "t.yaml"
    tree.write_text(TREE)
    done = _cli("run", "--quiet", str(tree), "--trace", str(full), cwd=tmp_path)
    assert done.returncode == 2 and "not a regular file" in done.stderr, done
    assert "ticks" not in done.stderr  # refused before it ran


def test_a_tree_too_large_to_draw_gets_its_dot_source_and_a_clear_refusal(tmp_path: Path) -> None:
    # a 48,000-node tree (within the file cap) had Graphviz working for minutes
    count = [0]

    def node(depth: int) -> str:
        count[0] += 1
        if depth == 0:
            return f"{{type: wait, name: w{count[0]}, duration: 1 s}}"
        kids = f"{node(depth - 1)}, {node(depth - 1)}"
        return f"{{type: sequence, name: s{count[0]}, children: [{kids}]}}"

    tree = tmp_path / "deep.yaml"
    tree.write_text(f"name: deep\nroot: {node(12)}\n")
    out = tmp_path / "deep.svg"
    with pytest.raises(InputError, match=r"8,191 nodes are too many to draw \(at most 5,000") as e:
        pirate_bt.render_tree(tree, out)
    # named by the file asked for, not 'out:' (the API's argument, which a command line
    # user never typed: probe 16)
    assert str(e.value).startswith(f"{out}: 8,191 nodes"), e.value
    assert not out.exists() and (tmp_path / "deep.dot").is_file()


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.parametrize(
    "args",
    [
        ("validate", "f.jsonl"),
        ("trace", "summary", "f.jsonl"),
        ("render", "f.jsonl", "-o", "q.svg"),
        ("network", "perturb", "bend-right", "--seed", "1", "-o", "f.yaml"),
    ],
)
def test_a_named_pipe_as_a_trace_to_read_or_a_network_to_write_is_refused_at_once(
    tmp_path: Path, args: tuple[str, ...]
) -> None:
    # each waited for ever on a pipe nobody writes to (or reads from)
    os.mkfifo(tmp_path / "f.jsonl")
    os.mkfifo(tmp_path / "f.yaml")
    done = _cli(*args, cwd=tmp_path)
    assert done.returncode == 2, done
    assert done.stderr.count("\n") == 1 and ("named pipe" in done.stderr or "a pipe" in done.stderr)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.jsonl", "f.yaml"]


def test_a_command_with_its_standard_output_closed_still_works(tmp_path: Path) -> None:
    # 'validate patrol.yaml >&-' was 'internal error: AttributeError', exit 1: py_trees
    # reads the encoding of the standard output when it is imported
    done = subprocess.run(
        [sys.executable, "-m", "pirate_bt", "validate", str(ROOT / "trees" / "straight.yaml")],
        preexec_fn=lambda: os.close(1),
        stderr=subprocess.PIPE,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert "internal error" not in done.stderr


@pytest.mark.parametrize("verb", ["export", "import"])
def test_an_output_named_as_a_folder_is_refused_not_written_without_its_slash(
    tmp_path: Path, verb: str
) -> None:
    # 'export btcpp bend.yaml -o x.xml/' wrote a file x.xml
    source = str(ROOT / "trees" / "bend.yaml")
    if verb == "import":
        assert _cli("export", "btcpp", source, "-o", "b.xml", cwd=tmp_path).returncode == 0
        source = "b.xml"
    target = "x.xml/" if verb == "export" else "x.yaml/"
    done = _cli(verb, "btcpp", source, "-o", target, cwd=tmp_path)
    assert done.returncode == 2 and f"-o: {target} ends in '/', a folder" in done.stderr, done
    assert not (tmp_path / target.rstrip("/")).exists()
