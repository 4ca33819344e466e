"""The ``pirate-bt`` command.

Verbs live in their own modules and are imported only when chosen, so
``pirate-bt --help`` starts fast. Each verb module has ``configure(parser)`` and
``run(args) -> int``. Errors become one line each on stderr and the exit codes
of DESIGN.md: 0 success, 1 the tree or mission failed (robot left safe), 2 invalid
input, 3 link or hardware error. ``--debug`` (before or after the verb) shows tracebacks.

Interruptions: SIGTERM, and SIGHUP unless ignored (``nohup``), are handled as Ctrl-C
(SIGINT) is, so a running tree is stopped by the runner and the robot left in its
safe state (the run then ends with 1, as every run that does not succeed). An
interrupt outside a run (loading, planning, writing outputs) exits 130 for SIGINT,
143 for SIGTERM and 129 for SIGHUP. A file that cannot be
read or written (a directory, a missing folder that cannot be made, a full disk)
is one line naming it, exit 2. ``-o -`` is standard output for the verbs that write
text (:func:`write_to_stdout`) and refused by every other output (:func:`check_output`,
:func:`check_folder_output`). A reader of standard output or error that went away
(``| head -1``) leaves the exit code as it is; standard output that cannot be
written (``> /dev/full``) is one line, exit 2 (:mod:`pirate_bt.cli.streams`).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import stat
import sys
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from pirate_bt.cli.parser import EXIT_INPUT, EmptyValue, Parser

__all__ = [
    "COMMANDS",
    "STDOUT",
    "Terminated",
    "as_option",
    "check_folder_output",
    "check_output",
    "main",
    "refuse_pipe",
    "said_path",
    "stdout_open",
    "utf8_text",
    "write_to_stdout",
]

# verb -> (module, one-line help). Later issues add their verbs here.
COMMANDS: dict[str, tuple[str, str]] = {
    "validate": ("pirate_bt.cli.validate", "check robot descriptions and other pirate_bt files"),
    "schema": ("pirate_bt.cli.schema", "print the JSON Schema of a file kind"),
    "robot": ("pirate_bt.cli.robot", "show a robot description's board table, or draw it"),
    "render": ("pirate_bt.cli.render", "draw a tree (.dot/.svg/.png), coloured by a trace tick"),
    "trace": ("pirate_bt.cli.trace", "read a trace back: summary, show a tick, plot"),
    "demo": ("pirate_bt.cli.demo", "the main job: run the showcase and write its outputs"),
    "sim": ("pirate_bt.cli.sim", "serve the simulator on a pty or TCP port, in real time"),
    "run": ("pirate_bt.cli.run", "run a behaviour tree against the simulator or a robot"),
    "teleop": ("pirate_bt.cli.teleop", "drive the robot or simulator by keys (checked)"),
    "mission": ("pirate_bt.cli.mission", "plan a route on its pipe network and run it"),
    "navigate": ("pirate_bt.cli.navigate", "let a navigator choose every step (planner code)"),
    "survey": ("pirate_bt.cli.survey", "map a network with no drawing, write it as a network file"),
    "network": ("pirate_bt.cli.network", "as-built variants of a pipe network (perturb, edit)"),
    "campaign": ("pirate_bt.cli.campaign", "run many seeded runs locally or on Dask; report"),
    "export": ("pirate_bt.cli.export", "write a tree in another tool's format (BT.CPP XML)"),
    "import": ("pirate_bt.cli.importer", "read a tree from another tool's format (BT.CPP XML)"),
}

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_LINK = 3
EXIT_SIGINT = 130
EXIT_SIGTERM = 143


class Terminated(KeyboardInterrupt):
    """SIGTERM (or SIGHUP: the terminal closed, an ssh session dropped), raised in the
    main thread as Ctrl-C raises ``KeyboardInterrupt``.

    A ``KeyboardInterrupt``, so everything that stops safely on Ctrl-C (the runner:
    running nodes stopped, the robot in its safe state, the trace's end record) does
    the same; its text names the signal, and :attr:`exit_code` is 128 + its number
    (143 for SIGTERM, 129 for SIGHUP).
    """

    def __init__(self, name: str = "SIGTERM") -> None:
        super().__init__(name)
        self.signal_name = name

    @property
    def exit_code(self) -> int:
        number = getattr(signal, self.signal_name, None)
        return 128 + int(number) if number is not None else EXIT_SIGTERM


def _terminate(signum: int, frame: object) -> None:
    # Once: a second signal kills at once, as before, should the safe stop hang.
    signal.signal(signum, signal.SIG_DFL)
    raise Terminated(signal.Signals(signum).name)


def check_output(path: str | os.PathLike[str], option: str = "-o") -> None:
    """Refuse an output path that can never be written, before any work is done, named
    by its option (``errors.output_argument``, the API's rule).

    Raises:
        InputError: ``path`` is a folder, a named pipe or a socket, a file is on its
            way, the system refuses the name, or its folder takes no file.
    """
    import tempfile

    from pirate_bt.errors import InputError, output_argument

    if os.fspath(path) == STDOUT:  # was a file named "-" (export btcpp -o -: "wrote -")
        raise InputError(
            f"{option} -: this command writes a file, not standard output; name the file"
        )
    if isinstance(path, str) and path.endswith(("/", os.sep)):  # Path() drops it: x.xml/
        raise InputError(f"{option}: {path} ends in '/', a folder; name the file to write")
    target = output_argument(path, option)
    refuse_pipe(target, option)
    # A folder that exists but takes no file (read-only, /proc): found now, not after
    # a survey or a campaign has run. Probed with a file made and removed at once in
    # the nearest folder that exists (the others are made in it).
    folder = next((p for p in target.absolute().parents if p.exists()), None)
    if folder is None:
        return
    try:
        handle, probe = tempfile.mkstemp(dir=folder, prefix=".pirate-bt-probe-")
    except OSError as exc:
        raise InputError(
            f"{option}: cannot write {target}: {folder} takes no file"
            f" ({exc.strerror or type(exc).__name__})"
        ) from None
    os.close(handle)
    os.unlink(probe)


def refuse_pipe(path: str | os.PathLike[str], option: str) -> None:
    """Refuse an output that is a named pipe or a socket (a link to one too): a named
    pipe nobody read was waited on for ever (``render -o``, ``robot header -o``, ``trace
    plot -o``, ``trace export -o x.mcap``, a mission's ``plot.png``), and a socket
    cannot be opened. A device (``/dev/null``) is written in place
    (:func:`pirate_bt.atomic.write_atomically`), as before.

    Raises:
        InputError: ``path`` is a named pipe or a socket, named by ``option``.
    """
    try:  # followed, as a write would follow a link
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return
    if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):
        from pirate_bt.errors import MAX_PATH, InputError, shown

        kind = "a named pipe" if stat.S_ISFIFO(mode) else "a socket"
        raise InputError(
            f"{option}: {shown(os.fspath(path), MAX_PATH)} is {kind}, not a file to write"
        )


def as_option(exc: Exception, parameter: str, option: str) -> None:
    """Raise the library's ``exc`` again with the parameter its message begins with
    (``out_path: cannot write t.mcap: No space left on device``) named as the option
    typed (``-o: ...``); return for any other message.

    Raises:
        InputError: ``exc``'s message begins with ``parameter: ``.
    """
    from pirate_bt.errors import InputError

    named = _option_named(str(exc), parameter, option)
    if named is not None:
        raise InputError(named) from None


def _option_named(text: str, parameter: str, option: str) -> str | None:
    """``text`` with the ``parameter: `` it begins with written ``option: ``, or ``None``
    when it does not begin so: the one rewording of :func:`as_option` and ``--port``'s."""
    if text.startswith(f"{parameter}: "):
        return f"{option}: {text[len(parameter) + 2 :]}"
    return None


STDOUT = "-"
"""``-o -``: standard output, for a verb whose output is text (``export``, ``import``,
``robot header``, ``network``); every other output refuses it (:func:`check_output`)."""


def check_folder_output(path: str | os.PathLike[str] | None, option: str = "--output") -> None:
    """Refuse ``-`` for a folder of outputs (``mission --output -`` made a folder named
    ``-``): it cannot be standard output.

    Raises:
        InputError: ``path`` is ``-``.
    """
    from pirate_bt.errors import InputError

    if path is not None and os.fspath(path) == STDOUT:
        raise InputError(f"{option} -: a folder of outputs, not standard output; name the folder")


_stdout_closed = False
"""Whether this command started with standard output closed (``>&-``)."""


def write_to_stdout(write: Callable[[Path], object], name: str) -> None:
    """``-o -``: ``write`` (the API's writer, given the path to write) writes into a
    temporary folder, as it would anywhere (checked, whole, or nothing), and the text
    goes to standard output; the folder is removed either way. ``name`` is the file's
    name in it (its suffix may pick the format)."""
    import tempfile

    stdout_open(name)
    with tempfile.TemporaryDirectory(prefix="pirate-bt-") as folder:
        path = Path(folder) / name
        write(path)
        text = path.read_text(encoding="utf-8")
    sys.stdout.write(text)
    sys.stdout.flush()


def stdout_open(name: str) -> None:
    """Refuse to write ``name`` to standard output when the command started with it
    closed (``>&-``): :func:`main` put the null device in its place (py_trees reads
    its encoding at import), where the text went nowhere while the command said
    nothing and exited 0.

    Raises:
        InputError: standard output is closed.
    """
    if _stdout_closed:
        from pirate_bt.errors import InputError

        raise InputError(f"standard output is closed; {name} not written")


def utf8_text(value: str) -> str:
    """An argparse ``type`` for a name written into a file (a network's name, a tee's
    id): text, not bytes that are no UTF-8 (``$'\\xff'``, read as ``'\\udcff'``), which
    failed only when the file was written, after the work, in an internal error.

    Raises:
        argparse.ArgumentTypeError: ``value`` holds bytes that are no UTF-8.
    """
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        from pirate_bt.errors import bytes_escaped

        raise argparse.ArgumentTypeError(f"'{bytes_escaped(value)}' is not UTF-8 text") from None
    return value


def _version() -> str:
    from pirate_bt._version import __version__

    return __version__


def _top_parser() -> argparse.ArgumentParser:
    verbs = "\n".join(f"  {name:<10} {text}" for name, (_, text) in COMMANDS.items())
    parser = Parser(
        prog="pirate-bt",
        description="Behaviour-tree autonomy for the PIRATE pipe-inspection robot.",
        epilog=f"commands:\n{verbs}\n\nexit codes: 0 ok, 1 failed (robot safe), 2 bad input,"
        " 3 link/hardware error\n'pirate-bt COMMAND --help' shows a command's options.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"pirate-bt {_version()}")
    parser.add_argument(
        "--debug", action="store_true", help="show tracebacks and debug logs (also after COMMAND)"
    )
    parser.add_argument(
        "--log",
        action="append",
        default=[],
        metavar="SUBSYSTEM=LEVEL",
        help="log level per subsystem, e.g. --log link=debug (repeatable)",
    )
    parser.add_argument("command", nargs="?", choices=sorted(COMMANDS), metavar="COMMAND")
    return parser


def _configure_logging(specs: Sequence[str], debug: bool) -> None:
    logging.basicConfig(
        level=logging.DEBUG if debug else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    from pirate_bt.errors import InputError

    levels = ("debug", "info", "warning", "error", "critical")
    chosen: dict[str, tuple[str, str]] = {}  # logger -> (spec, level)
    for spec in specs:
        name, equals, level = spec.partition("=")
        if not name or not equals or level.lower() not in levels:
            raise InputError(
                f"bad --log {spec[:80]!r}: write SUBSYSTEM=LEVEL, e.g. link=debug, with a"
                f" level of {', '.join(levels)}"
            )
        logger_name = name if name.startswith("pirate_bt") else f"pirate_bt.{name}"
        _check_subsystem(spec, logger_name)
        first = chosen.setdefault(logger_name, (spec, level.lower()))
        if first[1] != level.lower():  # the last was taken, without a word
            raise InputError(
                f"--log: {first[0][:80]!r}, then {spec[:80]!r}: two levels for one"
                " subsystem; give one"
            )
    for logger_name, (_, level) in chosen.items():
        logging.getLogger(logger_name).setLevel(logging.getLevelName(level.upper()))


def _check_subsystem(spec: str, logger_name: str) -> None:
    """Refuse a subsystem the library has no logger under (``--log saftey=debug`` set a
    level nothing logs at, silently)."""
    import difflib
    import pkgutil

    import pirate_bt
    from pirate_bt.errors import InputError

    parts = logger_name.split(".")
    known = {m.name for m in pkgutil.iter_modules(pirate_bt.__path__)} | {"trees"}
    if parts[0] == "pirate_bt" and (len(parts) == 1 or parts[1] in known):
        return
    name = parts[1] if parts[0] == "pirate_bt" and len(parts) > 1 else logger_name
    shown = sorted(k for k in known if not k.startswith("_"))
    close = difflib.get_close_matches(name, shown, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise InputError(
        f"bad --log {spec[:80]!r}: no subsystem {name[:40]!r}{hint} (subsystems:"
        f" {', '.join(shown)})"
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    global _stdout_closed
    _stdout_closed = sys.stdout is None
    for name in ("stdout", "stderr"):
        if getattr(sys, name) is None:  # closed by the caller (>&-): py_trees reads
            setattr(sys, name, open(os.devnull, "w"))  # noqa: SIM115  its encoding at import
    if sys.stdin is None:  # <&-: no terminal (teleop says so), not an AttributeError
        sys.stdin = open(os.devnull)  # noqa: SIM115
    from pirate_bt.cli import streams

    try:
        # from the first instruction: a Ctrl-C or SIGTERM while the command's modules
        # load is one line and 130 or 143, as during the command, not a traceback
        with _sigterm_as_interrupt(), streams.watched():
            code = _main(argv)
    except KeyboardInterrupt as exc:
        code = _interrupted(exc)
    except BrokenPipeError:  # --help or --version into a closed pipe (| head -1)
        code = EXIT_OK
    except OSError as exc:  # --help or --version onto a full device
        if not streams.stdout_failure(exc):
            raise
        print(f"pirate-bt: {streams.describe(exc)}", file=sys.stderr)
        code = EXIT_INPUT
    # now, not at the interpreter's exit: a reader that went away is no error, a full
    # device is one line and exit 2, not "Exception ignored" and exit 120
    return streams.finish(code)


def _interrupted(exc: KeyboardInterrupt) -> int:
    """Say how a Ctrl-C (or a signal) ended the command; its exit code."""
    ended = sys.modules.get("pirate_bt.run_result")  # loaded by any run
    if ended is not None and isinstance(exc, ended.RunInterrupted):
        # it came as a run ended (a node's terminate()), let out once the robot was
        # safe and the outputs written: a failed run, exit 1, not "nothing has moved"
        print(
            f"pirate-bt: FAILURE - {exc.result.message}; the robot was left in its safe state",
            file=sys.stderr,
        )
        return EXIT_FAILED
    if isinstance(exc, Terminated):
        print(f"pirate-bt: terminated ({exc.signal_name})", file=sys.stderr)
        return exc.exit_code
    print("pirate-bt: interrupted", file=sys.stderr)
    return EXIT_SIGINT


def _ros2_options_alone(parser: Parser, args: argparse.Namespace, given: list[str]) -> None:
    """``--ros-domain-id`` or ``--ros-namespace`` without ``--ros2`` was dropped without
    a word (``run T --ros-domain-id 5``, exit 0; the API refuses it)."""
    if "ros2" in vars(args) and args.ros2 is None:
        for option in ("--ros-domain-id", "--ros-namespace"):
            if any(a == option or a.startswith(f"{option}=") for a in given):
                parser.error(f"{option} is for --ros2: add --ros2 [ENDPOINT] or leave it out")


def _port_named(text: str, exc: Exception, args: argparse.Namespace) -> str:
    """A verb's ``--port`` named as typed in an error about it, as :func:`as_option`
    names other parameters: the API's ``port:`` (``port: 'bogus:x' is not a serial port
    ...``), or a URL refused as input before it opened (``PortURLError``, which carries
    the URL: ``cannot open bogus://x: no URL scheme 'bogus' here: ...``), raised by
    every verb's connection, so named here once. A port that cannot be opened (a link
    error) is named by its URL only. The error's exit code is kept."""
    if getattr(args, "port", None) is None:
        return text
    if getattr(exc, "port_url", None) and getattr(exc, "exit_code", None) == EXIT_INPUT:
        text = f"port: {text}"  # the URL's parameter, which its message does not name
    return _option_named(text, "port", "--port") or text


def _main(argv: Sequence[str] | None) -> int:
    args_list = list(sys.argv[1:] if argv is None else argv)
    top = _top_parser()
    # Split global options from the verb and its own arguments.
    split = next((i for i, a in enumerate(args_list) if a in COMMANDS), len(args_list))
    try:
        top_args = top.parse_args(args_list[: split + 1] if split < len(args_list) else args_list)
    except SystemExit as exc:  # --help, --version, or a usage error already printed
        return EXIT_INPUT if exc.code not in (0, None) else EXIT_OK
    except EmptyValue as exc:
        print(f"pirate-bt: {exc}", file=sys.stderr)
        return EXIT_INPUT
    if top_args.command is None:
        top.print_help(sys.stderr)
        return EXIT_INPUT
    module_name, text = COMMANDS[top_args.command]
    module = importlib.import_module(module_name)
    sub = Parser(prog=f"pirate-bt {top_args.command}", description=text)
    module.configure(sub)
    rest = args_list[split + 1 :]
    end = rest.index("--") if "--" in rest else len(rest)  # what follows "--" is not ours
    debug: bool = top_args.debug or "--debug" in rest[:end]
    rest = [a for i, a in enumerate(rest) if i >= end or a != "--debug"]
    try:
        args = sub.parse_args(rest)
        _ros2_options_alone(sub, args, rest[: rest.index("--")] if "--" in rest else rest)
    except SystemExit as exc:
        return EXIT_INPUT if exc.code not in (0, None) else EXIT_OK
    except EmptyValue as exc:
        print(f"pirate-bt: {exc}", file=sys.stderr)
        return EXIT_INPUT
    args.debug = debug
    from pirate_bt.errors import PirateError

    try:
        _configure_logging(top_args.log, debug)
        code: int = module.run(args)  # SIGTERM and Ctrl-C: main's handlers, as loading
        return code
    except PirateError as exc:
        if debug:  # the traceback too, and the same exit code (a raise made every one 1)
            traceback.print_exc()
        said = _typed_escaped(_port_named(str(exc), exc, args), args_list)
        for line in said.splitlines() or [type(exc).__name__]:
            print(f"pirate-bt: {line}", file=sys.stderr)
        return exc.exit_code
    except OSError as exc:
        from pirate_bt.cli import streams

        if isinstance(exc, BrokenPipeError) and streams.stdout_failure(exc):
            return EXIT_OK  # the reader of standard output went away (| head -1)
        # any other broken pipe (a helper process's, a socket's) is an error of the
        # command, said in one line: until 2026-11-30 every one was exit 0, unsaid
        if debug:
            traceback.print_exc()
        print(f"pirate-bt: {_typed_escaped(_os_error(exc), args_list)}", file=sys.stderr)
        return EXIT_INPUT
    except Exception as exc:
        if debug:
            raise
        print(
            f"pirate-bt: internal error: {type(exc).__name__}: {exc} (rerun with --debug)",
            file=sys.stderr,
        )
        return EXIT_FAILED


def said_path(path: str | os.PathLike[str]) -> str:
    """A path for a line of output (``wrote PATH``, ``drew PATH``): as it is when
    printable, else escaped (``a\\nb.dot``), so that a file named with a newline is
    not said on two lines."""
    text = os.fspath(path)
    return text if text.isprintable() else repr(text)[1:-1]


def _typed_escaped(text: str, typed: Sequence[str]) -> str:
    """``text`` with each argument typed that holds a control character (a file named
    ``$'a\\nb.jsonl'``) shown escaped, as the file checks show it (``a\\nb.yaml:1:1``):
    a message naming it was cut into two lines, ``pirate-bt: a`` and ``pirate-bt:
    b.jsonl: cannot read trace: ...``. The longest first (``--trace=x`` holds ``x``)."""
    for arg in sorted({a for a in typed if not a.isprintable()}, key=len, reverse=True):
        for value in (arg, arg.partition("=")[2]):
            if value and not value.isprintable() and value in text:
                text = text.replace(value, repr(value)[1:-1])
    return text


def _os_error(exc: OSError) -> str:
    """One line for a file that could not be read or written: the file, then why."""
    from pirate_bt.cli import streams

    if streams.stdout_failure(exc):  # no file name: "No space left on device" alone
        return streams.describe(exc)
    why = exc.strerror or str(exc) or type(exc).__name__
    name = exc.filename2 if exc.filename2 is not None else exc.filename
    return f"{name}: {why}" if name is not None else why


class _sigterm_as_interrupt:
    """SIGTERM, and SIGHUP unless it is ignored (``nohup``), raise :class:`Terminated`
    in the main thread while the verb runs: a closed terminal or a dropped ssh session
    stops the robot safely with one line, where it killed the process outright and left
    the drives to the bridge's watchdog.

    Restores the handlers before it on exit (``main`` also runs inside tests); does
    nothing off the main thread, where no handler can be set.
    """

    def __enter__(self) -> None:
        self._previous: dict[int, Any] = {}
        names = ("SIGTERM", "SIGHUP")
        for number in (getattr(signal, n) for n in names if hasattr(signal, n)):
            try:
                before = signal.getsignal(number)
                if number != signal.SIGTERM and before is signal.SIG_IGN:
                    continue  # nohup: the caller asked for the run to outlive its terminal
                signal.signal(number, _terminate)
            except ValueError:  # not the main thread
                return
            self._previous[number] = before

    def __exit__(self, *exc: object) -> None:
        for number, before in self._previous.items():
            signal.signal(number, before or signal.SIG_DFL)
