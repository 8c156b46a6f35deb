"""The firmware in real time behind a pseudo-terminal (simavr's uart_pty part), talked to by
the host's own link stack: SerialTransport, Decoder, Tracker. The serial path a driver will
use, end to end, with no robot. Takes about 2 s of wall time."""

from __future__ import annotations

import subprocess
import threading
import time

import pytest

from mona_controller.link.frame import Decoder, Frame
from mona_controller.link.payloads import COMMAND, TELEMETRY, Command, Telemetry
from mona_controller.link.sequence import Counter16, Tracker
from mona_controller.link.transport import SerialTransport

SECONDS = 3.0


@pytest.fixture
def firmware_on_a_pty(monasim):
    """(pty path, the wheel events as they come) of a firmware running in real time."""
    elf, host = monasim
    process = subprocess.Popen([str(host), str(elf), '--pty', str(SECONDS)],
                               stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, text=True)
    lines: list[str] = []
    ready = threading.Event()

    def read() -> None:
        assert process.stdout is not None
        for line in process.stdout:
            lines.append(line)
            if line.startswith('P '):
                ready.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        assert ready.wait(10), lines
        path = next(line.split()[1] for line in lines if line.startswith('P '))
        yield path, lines
    finally:
        process.kill()
        process.wait(timeout=10)


def test_the_serial_transport_drives_the_firmware_over_a_pty(firmware_on_a_pty):
    path, events = firmware_on_a_pty
    decoder, tracker, seq = Decoder(), Tracker(), Counter16(1)
    telemetry: list[Frame] = []
    with SerialTransport(path) as line:
        start = time.monotonic()
        next_command = start
        sent = 0
        while time.monotonic() - start < 0.8:
            if time.monotonic() >= next_command:
                line.send(Frame(1, seq.next(), 0x77, COMMAND,
                                Command(700, -700, True).encode()).encode())
                sent += 1
                next_command += 0.05
            telemetry.extend(decoder.feed(line.receive(0.01)))
        # then silence: the firmware's watchdog stops the wheels
        quiet = time.monotonic()
        while time.monotonic() - quiet < 0.5:
            telemetry.extend(decoder.feed(line.receive(0.05)))
    reports = [Telemetry.decode(frame.payload) for frame in telemetry if frame.kind == TELEMETRY]
    for frame in telemetry:
        tracker.observe(frame.robot, frame.seq, frame.nonce)
    stream = tracker.streams[1]
    # 1.3 s of telemetry at 20 Hz (we may join mid-frame: garbage, never a reject)
    assert len(reports) >= 15 and sum(decoder.rejected.values()) <= 1
    assert (stream.lost, stream.duplicated, stream.reboots) == (0, 0, 0)
    assert any(not r.stopped and r.flags & 0x02 for r in reports)
    assert max(r.ack for r in reports) == sent
    assert reports[-1].stopped
    wheels = [tuple(map(int, event.split()[2:])) for event in events if event.startswith('W ')]
    assert (186, 0, 186, 1, 1) in wheels  # pwm(700) = 25 + 161 = 186
    assert wheels[-1] == (0, 0, 0, 0, 0)
