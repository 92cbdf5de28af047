"""How fast the haptic loop samples a device written in Python, as the rest of the program goes on.

The loop's thread takes the GIL for each call into the device; it gets it at once while the main
thread waits or works inside Kiji (which releases the GIL), and only at Python's switch interval
(5 ms by default, sys.getswitchinterval) while the main thread runs Python code. Prints the rate,
the period's jitter and the force callback's time for each case::

    python -m kiji.examples.haptic_rates [SECONDS]
"""
from __future__ import annotations

import sys
import time

import numpy as np

import kiji


class PythonPen(kiji.InputDevice):
    """A pen held still over the cloth, its forces counted."""

    def __init__(self):
        super().__init__()
        self.sent = 0

    def sample(self):
        return kiji.ToolEvent("move", (0.5, 0.5, 0.002))

    def set_force(self, force):
        self.sent += 1


def run(seconds: float) -> list[tuple[str, dict]]:
    s = kiji.Session()
    s.add_garment(kiji.rectangle(1.0, 1.0, spacing=0.01))  # about 10,000 vertices
    s.begin("paint", (0.5, 0.5, 0.002))
    rows = []

    def case(name, work):
        pen = PythonPen()
        loop = kiji.HapticLoop(pen)
        loop.set_tool(s, "paint")
        loop.publish(kiji.take_snapshot(s, 0, (0.5, 0.5, 0.0), 0.05))
        with loop:
            work()
        rows.append((name, loop.stats()))

    case("main thread waiting (time.sleep)", lambda: time.sleep(seconds))

    def python_work():
        end = time.perf_counter() + seconds
        x = np.zeros(1000)
        while time.perf_counter() < end:
            for i in range(1000):  # pure Python: holds the GIL between switch intervals
                x[i % 1000] += 1.0

    case("main thread running Python code", python_work)

    def simulate():
        end = time.perf_counter() + seconds
        while time.perf_counter() < end:
            s.step()  # Kiji's step releases the GIL

    s.cancel()
    case("main thread simulating (session.step)", simulate)
    return rows


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    seconds = float(argv[0]) if argv else 2.0
    print(f"haptic loop (target 1000 Hz) with a device written in Python, {seconds:g} s a case, "
          f"switch interval {sys.getswitchinterval() * 1000:g} ms")
    for name, st in run(seconds):
        print(f"  {name:40s} {st['rate_hz']:7.0f} Hz  jitter {st['period_jitter_us']:7.0f} us  "
              f"force callback median {st['force_median_us']:.1f} us  realtime {st['realtime']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
