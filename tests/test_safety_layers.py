"""The import rule, the teleop session and the factory's helpers."""

from __future__ import annotations

import ast
import io
import re
from pathlib import Path

from pirate_bt.cli.teleop import TeleopSession
from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkTimeout
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Mode, Reason, Supervisor
from pirate_bt.safety.factory import wait_for_state
from pirate_bt.safety.testing import FakePort

PACKAGE = Path(__file__).resolve().parent.parent / "pirate_bt"
ABOVE_SAFETY = ("behaviours", "treefile", "runner", "trace", "render", "task", "cli")
_MODULE_REF = re.compile(r"^(?P<module>pirate_bt(?:\.[a-z_]+)+)(?::[A-Za-z_]+)?$")


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
        elif (
            isinstance(node, ast.Call)
            and getattr(node.func, "attr", "") == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
        ):
            found.add(str(node.args[0].value))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            # A module named in a string ("pirate_bt.link:open_link") is imported by
            # someone later (importlib, a registry table): that is an import too.
            ref = _MODULE_REF.match(node.value)
            if ref:
                found.add(ref["module"])
    return found


def test_nothing_above_safety_imports_the_link() -> None:
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        top = rel.parts[0].removesuffix(".py")
        if top not in ABOVE_SAFETY:
            continue
        for name in _imports(path):
            if name == "pirate_bt.link" or name.startswith("pirate_bt.link."):
                offenders.append(f"{rel}: {name}")
    assert not offenders, "only safety/ and sim/ may import pirate_bt.link: " + "; ".join(offenders)


def test_the_rule_scanner_sees_imports(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text(
        "from pirate_bt.link import open_link\nimport pirate_bt.link.session\n"
        "OPEN = resolve('pirate_bt.link.robot_link:open_link')\n"
        "NOTE = 'docs may say pirate_bt.link is below safety'\n"
    )
    found = _imports(bad)
    assert {"pirate_bt.link", "pirate_bt.link.session", "pirate_bt.link.robot_link"} <= found
    assert not any(" " in name for name in found)


def test_teleop_keys_go_through_the_supervisor() -> None:
    robot = load_robot()
    clock = SimClock()
    port = FakePort(robot, clock, physics=True)
    sup = Supervisor(port, clock, mode=Mode.MANUAL)
    out = io.StringIO()
    session = TeleopSession(sup, out)
    for key in "a" + "r" + "F" + "a" + "w?" + "e" + "w" + "x" + "q":
        session.step()
        if not session.press(key):
            break
        clock.advance(0.05)
    text = out.getvalue()
    assert Reason.ROTATE_NEEDS_ONE_CLAMPED.value in text  # 'a' before any clamp
    assert port.half_clamped(Half.REAR)
    assert "e-stop" in text and Reason.ESTOP_LATCHED.value in text
    assert sup.mode is Mode.MANUAL  # 'x' reset the e-stop
    assert len(port.violations) == 0


def test_wait_for_state_times_out() -> None:
    robot = load_robot()
    clock = SimClock()

    class Silent(FakePort):
        def state(self):  # type: ignore[no-untyped-def]
            return None

    port = Silent(robot, clock)
    try:
        wait_for_state(port, clock, 0.1)
    except LinkTimeout:
        pass
    else:  # pragma: no cover
        raise AssertionError("expected LinkTimeout")
    wait_for_state(FakePort(robot, clock), clock, 0.1)


def test_open_supervisor_starts_the_simulator_by_default() -> None:
    from pirate_bt.clock import SimClock as _SimClock
    from pirate_bt.errors import ConfigurationError
    from pirate_bt.safety import Clamp
    from pirate_bt.safety.factory import open_supervisor

    sup = open_supervisor(network="straight", seed=2)
    try:
        assert isinstance(sup.clock, _SimClock) and sup.simulator is not None
        assert sup.simulator.network.name == "straight"
        assert sup.command(Clamp(Half.REAR, 0.5)).ok
        for _ in range(25):
            sup.clock.sleep(0.05)
            sup.tick()
        assert sup.half_states()[Half.REAR].value == "clamped"
        assert sup.simulator.truth().halves[Half.REAR].clamped
    finally:
        sup.close()
    sup.close()  # idempotent
    try:
        open_supervisor(url="loop://", network="straight")
    except ConfigurationError:
        pass
    else:  # pragma: no cover
        raise AssertionError("simulator options with a URL must be refused")


def test_teleop_defaults_to_the_simulator(capsys: object) -> None:
    import argparse

    from pirate_bt.cli import teleop

    parser = argparse.ArgumentParser()
    teleop.configure(parser)
    args = parser.parse_args(["--sim", "straight", "--keys", "r" + "." * 25 + "?"])
    assert teleop.run(args) == 0
    out = capsys.readouterr().out  # type: ignore[attr-defined]
    assert "rear clamped" in out


def test_the_safety_commands_and_their_half_come_from_one_import() -> None:
    # docs/safety.md writes commands as `Clamp(Half.FRONT, ...)`: both from pirate_bt.safety
    import pirate_bt.safety as safety
    from pirate_bt.robot import Half

    assert safety.Half is Half and "Half" in safety.__all__
    assert safety.Clamp(safety.Half.FRONT, 0.5).half is Half.FRONT
