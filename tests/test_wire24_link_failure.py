"""A request given up while the tree sends nothing reaches the supervisor at its next tick.

Until 2026-12-01 the link said a request's failure (a setpoint table the bridge never
took, each of its tables sent again lost too) only at the next ``send``: a tree waiting
on a long ``wait`` after its command ran on, the drives at whatever the bridge last
had, and a tree that sent nothing more ended without the failure as its first cause
(the close only logged it). The supervisor's tick polls the link; the failure now
comes out of that poll, after the link's own problems (a bridge reset, a silence),
which stay the first cause when they are there.
"""

from __future__ import annotations

from test_link23_lossy_bulks import JOINT, _connect

from pirate_bt.errors import LinkError
from pirate_bt.safety import Supervisor


def test_a_table_never_taken_stops_a_waiting_tree_at_the_next_tick() -> None:
    link, tap, clock = _connect(lose=10**6)  # the bridge hears heartbeats, never a bulk
    supervisor = Supervisor(link, clock)
    supervisor.tick()
    link.send([JOINT])  # the tree's command, then a 5 s wait: no more sends
    start = clock.now()
    while not supervisor.in_safe_state and clock.now() - start < 5.0:
        clock.advance(0.05)  # a 20 Hz tick
        supervisor.tick()
    reason = supervisor.safe_state_reason or ""
    assert reason.startswith("link error while sending: 1 earlier request(s) failed; last:")
    assert "not acknowledged after 4 tries" in reason
    assert isinstance(supervisor.safe_state_error, LinkError)
    # given up after the table went again twice (3 x 4 tries), not at the wait's end
    assert len(set(tap.lost)) == 3
    assert clock.now() - start < 1.5
    link.close()
