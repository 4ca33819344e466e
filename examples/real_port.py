"""Run a tree on a real robot: a PIRATEbay bridge on a serial port or a pyserial URL.

Run from the repository root::

    python examples/real_port.py /dev/ttyACM0        # a robot on USB
    PIRATE_PORT=socket://robot:7000 python examples/real_port.py

With no port given, it starts the simulator as a separate process serving the
wire protocol on a local TCP port (``pirate-bt sim straight --tcp 0``), runs the
tree on it exactly as on a robot (wall clock, real link), and stops it after.
"""

import os
import subprocess
import sys

import pirate_bt


def run(port: str) -> pirate_bt.RunResult:
    # A short straight PAB: clamp both halves, drive 10 cm. Every command goes
    # through the protective layer; a failure leaves the robot in its safe state.
    return pirate_bt.run_tree("straight", port=port, params={"distance": "0.1 m"})


port = sys.argv[1] if len(sys.argv) > 1 else os.environ.get("PIRATE_PORT")
if port:
    result = run(port)
else:
    # No robot: the simulator in its own process, in real time, on 127.0.0.1
    # (port 0 picks a free one; it prints the URL to connect to).
    server = subprocess.Popen(
        [sys.executable, "-m", "pirate_bt", "sim", "straight", "--tcp", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,  # its log: the bridge's watchdog after we hang up
        text=True,
    )
    try:
        assert server.stdout is not None
        port = server.stdout.readline().strip()  # socket://127.0.0.1:PORT
        if not port:
            sys.exit("the simulator did not start")
        print(f"simulator serving on {port}")
        result = run(port)
    finally:
        server.terminate()
        server.wait(timeout=10)

print(result.summary())
print(f"link: {result.counters.retries} retries, {result.counters.crc_errors} CRC errors")
sys.exit(result.exit_code)  # 0 success, 1 failure, 3 link error
