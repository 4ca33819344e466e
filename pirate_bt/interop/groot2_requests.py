"""Groot2's requests, answered in the server's thread.

:meth:`_Requests._answer` turns one request (its header, and for some a second
part) into its reply: the tree's XML, the statuses, the blackboards, the hooks
set, inserted, removed or unlocked, the recorded transitions; or an error reply
(:func:`_error`), which never takes the server down. The wire format itself is
:mod:`pirate_bt.interop.groot2_protocol`.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from typing import Any

import py_trees

from pirate_bt.interop.groot2_hooks import _Hooks
from pirate_bt.interop.groot2_protocol import (
    ERROR,
    NOT_FOUND,
    NOT_RECOGNIZED,
    TWO_PARTS,
    WRONG_HEADER,
    HookError,
    RequestType,
    hooks_json,
    pack_transitions,
    parse_hooks,
    parse_remove,
    parse_unlock,
    reply_header,
    unpack_request,
)
from pirate_bt.interop.groot2_run import _REPLACED, BREAKPOINT, REPLACE, Unservable, _Run, logger
from pirate_bt.trace.structure import jsonable

__all__: list[str] = []  # parts of Groot2Server (groot2_server.py re-exports what is public)

SPLIT_NAMES_PER_BOARD = 4
SPLIT_SPARE = 64
"""A blackboard request naming fewer names than this many per blackboard of the tree,
and this many more, is split into its names (Groot2 names the subtree instances it
shows, each once); one naming more is searched for the tree's blackboards instead
(:func:`_known_names_in`)."""


class _Requests(_Hooks):
    """The request half of :class:`~pirate_bt.interop.groot2_server.Groot2Server`."""

    def _answer(self, parts: list[bytes]) -> list[bytes]:
        self._last_request = time.monotonic()
        self._heard = True
        self.requests += 1
        header = unpack_request(parts[0]) if parts else None
        if header is None:
            return _error(WRONG_HEADER)
        try:
            run = self._build()
        except Unservable as exc:  # logged once, when it was found
            return _error(str(exc))
        except Exception as exc:  # a tree that cannot be shown must not stop the server
            logger.exception("Groot2: cannot serve this tree")
            return _error(f"cannot serve this tree: {exc}")
        if run is None:
            return _error("no tree is running yet")
        reply = [reply_header(header, run.uuid)]
        kind = header.type
        try:
            if kind == RequestType.FULLTREE:
                reply.append(run.served.xml.encode("utf-8"))
            elif kind == RequestType.STATUS:
                with self._cond:
                    reply.append(bytes(self._status))
            elif kind in _TWO_PART:
                if len(parts) != 2:
                    return _error(TWO_PARTS)
                more = _TWO_PART[kind](self, run, parts[1])
                if isinstance(more, str):
                    return _error(more)
                reply += more
            elif kind == RequestType.HOOKS_DUMP:
                with self._cond:
                    reply.append(hooks_json(list(self._hooks.values())))
            elif kind == RequestType.REMOVE_ALL_HOOKS:
                with self._cond:
                    self._remove_all_locked()
            elif kind == RequestType.DISABLE_ALL_HOOKS:
                with self._cond:
                    for hook in self._hooks.values():
                        hook.enabled = False
                    self._cond.notify_all()
            elif kind == RequestType.GET_TRANSITIONS:
                with self._cond:
                    taken = list(self._transitions)
                    self._transitions.clear()
                reply.append(pack_transitions(taken))
            else:
                return _error(NOT_RECOGNIZED)
        except HookError as exc:
            return _error(str(exc))
        except Exception as exc:  # never let a request take the server down
            logger.exception("Groot2: answering a request failed")
            return _error(f"Unknown error while processing request: {exc}")
        return reply

    def _blackboard(self, run: _Run, names: bytes) -> list[bytes]:
        served = run.served
        if names.count(b";") < SPLIT_NAMES_PER_BOARD * (len(served.subtrees) + 2) + SPLIT_SPARE:
            # each name once: a request naming one many times asked for the live
            # blackboard that many times
            wanted = list(dict.fromkeys(names.decode("utf-8", "replace").split(";")))
        else:  # far more names than blackboards: the known ones looked for, unsplit
            wanted = _known_names_in(names, ["", served.main_id, *served.subtrees])
        dump: dict[str, Any] = {}
        main_id = run.served.main_id
        live: dict[str, Any] | None = None
        for name in wanted:
            if name == "" or (name == main_id and name not in run.served.subtrees):
                # the main tree's instance ("", as pirate_bt names it) or its tree ID
                # (as BT.CPP's publisher keys it): the live blackboard
                if live is None:
                    live = _live_blackboard()
                board = live
            elif name in run.served.subtrees:
                board = dict(run.served.subtrees[name])
            else:
                continue
            dump[name] = board or None  # BT.CPP's JSON of an empty blackboard is null
        value = jsonable(dump) if dump else None
        try:
            packed: bytes = self._msgpack.packb(value, use_bin_type=True)
        except UnicodeEncodeError:
            # a lone surrogate (a file name os.fsdecode made of bytes that are no UTF-8)
            # has no UTF-8: shown as U+FFFD, as in the tree's XML. Until 2026-11-30 every
            # blackboard request was an error reply, with a traceback in the run's log
            packed = self._msgpack.packb(_without_surrogates(value), use_bin_type=True)
        return [packed]

    def _insert(self, run: _Run, text: bytes) -> list[bytes] | str:
        hooks = parse_hooks(text)
        if run.robot is not None and any(h.mode == REPLACE for h in hooks):
            return _refusal(run)
        with self._cond:
            for hook in hooks:
                key = (hook.position, hook.uid)
                current = self._hooks.get(key)
                if current is not None:
                    was_breakpoint = current.mode == BREAKPOINT
                    current.update(hook)
                    if was_breakpoint and current.mode == REPLACE:
                        current.ready = True
                        self._cond.notify_all()
                elif hook.uid in run.served.node_of:  # BT.CPP ignores an unknown node
                    self._hooks[key] = hook
            self._generation += 1
        return []

    def _remove(self, run: _Run, text: bytes) -> list[bytes] | str:
        uid, position = parse_remove(text)
        with self._cond:
            if uid not in run.served.node_of or (position, uid) not in self._hooks:
                return NOT_FOUND
            self._remove_locked(position, uid)
        return []

    def _unlock(self, run: _Run, text: bytes) -> list[bytes] | str:
        uid, position, status, remove = parse_unlock(text)
        with self._cond:
            hook = self._hooks.get((position, uid))
            if uid not in run.served.node_of or hook is None:
                return NOT_FOUND
            if run.robot is not None and status in _REPLACED:
                return _refusal(run)
            hook.desired_status = status
            hook.once = hook.once or remove
            if hook.mode == BREAKPOINT:
                hook.ready = True
                self._cond.notify_all()
        return []

    def _record(self, run: _Run, command: bytes) -> list[bytes]:
        if command == b"start":
            with self._cond:
                self._record_t0_ns = time.perf_counter_ns()
                self._transitions.clear()
                self._recording = True
            return [str(time.time_ns() // 1000).encode()]
        if command == b"stop":
            with self._cond:
                self._recording = False
        return []


_TWO_PART: dict[int, Callable[[_Requests, _Run, bytes], Any]] = {
    RequestType.BLACKBOARD: _Requests._blackboard,
    RequestType.HOOK_INSERT: _Requests._insert,
    RequestType.HOOK_REMOVE: _Requests._remove,
    RequestType.BREAKPOINT_UNLOCK: _Requests._unlock,
    RequestType.TOGGLE_RECORDING: _Requests._record,
}


def _error(message: str) -> list[bytes]:
    return [ERROR, message.encode("utf-8")]


def _refusal(run: _Run) -> str:
    return (
        f"refused: replacing a node's result is allowed on the simulator only, and this"
        f" run is on a robot ({run.robot}); unlock with another status to let the node run"
    )


def _known_names_in(names: bytes, known: list[str]) -> list[str]:
    """The names of ``known`` that ``names`` (``;``-separated) holds, in the order they
    first appear there, as splitting it would give them: each looked for whole, the
    request never split.

    Splitting a request of a million ``;`` into a million names, and keeping each once,
    held the interpreter's lock for tens of milliseconds at a time: a client sending
    such requests back to back starved the tick and the link's threads (a run on a
    robot lost its link in half a second). Here each search is one short scan.
    """
    text = b";" + names + b";"
    first: dict[str, int] = {}
    for name in known:
        at = text.find(b";" + name.encode("utf-8", "replace") + b";")
        if at >= 0 and name not in first:
            first[name] = at
    return sorted(first, key=first.__getitem__)


_SURROGATE = re.compile("[\ud800-\udfff]")


def _without_surrogates(value: Any) -> Any:
    """``value`` (plain JSON data) with each lone surrogate of its text as U+FFFD."""
    if isinstance(value, str):
        return _SURROGATE.sub("\ufffd", value)
    if isinstance(value, dict):
        return {_without_surrogates(k): _without_surrogates(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_without_surrogates(v) for v in value]
    return value


def _live_blackboard() -> dict[str, Any]:
    """The py_trees blackboard, keys without their leading ``/``."""
    storage = dict(py_trees.blackboard.Blackboard.storage)
    return {key.lstrip("/"): value for key, value in storage.items()}
