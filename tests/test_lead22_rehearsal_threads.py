"""The rehearsal of an installed navigator (a fork) is skipped in a process with other
threads: a fork copies only the calling thread, so a lock another thread held stayed
held in the child for ever, and a navigator fine in every case was refused after the
case timeout as one that hangs."""

from __future__ import annotations

import threading

from pirate_bt.campaign.rehearsal import rehearse


def test_a_lock_another_thread_holds_does_not_make_a_navigator_hang() -> None:
    lock = threading.Lock()
    held, done = threading.Event(), threading.Event()

    def holder() -> None:
        with lock:
            held.set()
            done.wait(30)

    thread = threading.Thread(target=holder, daemon=True)
    thread.start()
    try:
        assert held.wait(10)

        def check() -> None:  # what making a navigator does: take a lock (imports, logging)
            with lock:
                pass

        rehearse("mine", check, timeout_s=1.0)  # raised "was still being made after 1 s"
    finally:
        done.set()
        thread.join(10)
