"""The classic Mona's firmware (firmware/mona) in simavr, the very image one would flash:
wheels through the deadband map, the 150 ms command watchdog, bad frames ignored, the boot
nonce across a reset, telemetry that mona_controller.link decodes. Times are simulated."""

from __future__ import annotations

import random

import pytest

from mona_controller.link.frame import Frame
from mona_controller.link.payloads import COMMAND, Command
from mona_controller.link.sequence import REBOOT, Tracker

CYCLES_PER_MS = 8000
DEADBAND = 25


def pwm(command: int) -> int:
    """The documented deadband map (docs/link.md): 0 -> 0, else 25 + |v| * 230 / 1000."""
    magnitude = min(abs(command), 1000)
    return 0 if magnitude == 0 else DEADBAND + (magnitude * (255 - DEADBAND) + 500) // 1000


def test_the_map_is_the_documented_one():
    assert [pwm(v) for v in (0, 1, 500, 1000, -1000)] == [0, 25, 140, 255, 255]


@pytest.mark.parametrize(('left', 'right'), [
    (0, 0), (1, -1), (500, 250), (1000, -1000), (-300, 0), (0, 999), (-1, 1000)])
def test_wheels_follow_commands_through_the_deadband_map(mona, left, right):
    mona.command(left, right, cleaner=left > 0)
    mona.run(10)
    assert mona.outputs == (pwm(left), int(left < 0), pwm(right), int(right < 0),
                            int(left > 0))


def test_a_sequence_of_commands_is_followed_in_order(mona):
    for left, right in [(200, 200), (-700, 700), (0, 0), (1000, 1000)]:
        mona.command(left, right)
        mona.run(20)
        assert mona.outputs[:4] == (pwm(left), int(left < 0), pwm(right), int(right < 0))


def test_the_watchdog_stops_the_wheels_150_ms_after_the_last_valid_command(mona):
    # Commands every 100 ms keep the wheels turning for a second
    for _ in range(10):
        mona.command(600, -600)
        mona.run(100)
    assert all(state[1] > 0 for state in mona.wheels[1:]), mona.wheels
    last = mona.delivered[-1]
    mona.run(300)
    moving = [state for state in mona.wheels if state[1] or state[3]]
    stop = next(state for state in mona.wheels if state[0] > last and state[1:] == (
        0, 0, 0, 0, 0))
    after_ms = (stop[0] - last) / CYCLES_PER_MS
    assert 150.0 <= after_ms <= 152.0, after_ms
    assert moving[-1][0] < stop[0]
    assert mona.reports()[-1].stopped and mona.reports()[-1].ack == mona.seq
    # While commands came, no report said stopped (but those before the first command)
    assert not [r for r in mona.reports() if r.stopped and 0 < r.ack < mona.seq]


def test_a_bad_crc_frame_is_ignored_and_counted(mona):
    rejected = mona.reports()[-1].rx_rejected
    bad = bytearray(Frame(1, 5, mona.nonce, COMMAND, Command(800, 800).encode()).encode())
    bad[-2] ^= 0xFF
    mona.send(bytes(bad))
    mona.run(60)
    assert mona.outputs == (0, 0, 0, 0, 0)
    assert mona.reports()[-1].rx_rejected == (rejected + 1) % 256
    # A corrupted byte inside the payload, then a good frame right behind it: resynchronised
    corrupt = bytearray(Frame(1, 6, mona.nonce, COMMAND, Command(900, 900).encode()).encode())
    corrupt[9] ^= 0x10
    mona.send(bytes(corrupt) + Frame(1, 7, mona.nonce, COMMAND,
                                     Command(300, 300).encode()).encode())
    mona.run(60)
    assert mona.outputs[:4] == (pwm(300), 0, pwm(300), 0)
    assert mona.reports()[-1].rx_rejected == (rejected + 2) % 256
    assert mona.reports()[-1].ack == 7


def test_commands_for_another_robot_and_stale_ones_are_ignored(mona):
    mona.command(400, 400, robot=2)
    mona.run(20)
    assert mona.outputs == (0, 0, 0, 0, 0)
    mona.command(400, 400, robot=0xFF)  # broadcast
    mona.run(20)
    assert mona.outputs[:4] == (pwm(400), 0, pwm(400), 0)
    mona.command(-900, -900, seq=mona.seq - 1)  # late: older than the one applied
    mona.run(20)
    assert mona.outputs[:4] == (pwm(400), 0, pwm(400), 0)


def test_a_reset_changes_the_boot_nonce(mona):
    mona.command(500, 500)
    mona.run(100)
    before = mona.telemetry[-1][1]
    mona.reset()
    mona.run(120)
    after = mona.telemetry[-1][1]
    assert after.nonce == (before.nonce + 1) % 65536
    assert mona.outputs == (0, 0, 0, 0, 0)  # a reboot starts with the wheels stopped
    tracker = Tracker()
    verdicts = [tracker.observe(frame.robot, frame.seq, frame.nonce)
                for _, frame in mona.telemetry]
    assert verdicts.count(REBOOT) == 1
    assert tracker.streams[1].lost == 0


def test_telemetry_decodes_with_the_link_decoder(mona):
    # IR channels right to left are A3 A2 A1 A0 A7; A6 is the battery (through a 1:2 divider)
    volts = {3: 3300, 2: 2000, 1: 1000, 0: 500, 7: 0, 6: 1850}
    for channel, millivolts in volts.items():
        mona.adc(channel, millivolts)
    mona.encoder('L', 12)
    mona.encoder('R', 5)
    mona.command(100, 100)
    mona.run(1000)
    reports = mona.reports()
    assert sum(mona.decoder.rejected.values()) == 0 and mona.decoder.garbage == 0
    times = [cycle for cycle, _ in mona.telemetry]
    periods = {round((b - a) / CYCLES_PER_MS) for a, b in zip(times, times[1:])}
    assert periods <= {49, 50, 51}, periods
    last = reports[-1]
    expected = [volts[ch] * 1023 // 3300 for ch in (3, 2, 1, 0, 7)]
    assert all(abs(a - b) <= 1 for a, b in zip(last.ir, expected)), (last.ir, expected)
    assert (last.left_ticks, last.right_ticks) == (12, 5)
    assert abs(last.battery_mv - 2 * 1850) <= 8
    assert last.ack == mona.seq
    tracker = Tracker()
    for _, frame in mona.telemetry:
        tracker.observe(frame.robot, frame.seq, frame.nonce)
    stream = tracker.streams[1]
    assert (stream.lost, stream.duplicated, stream.reboots) == (0, 0, 0)
    assert stream.received == len(mona.telemetry) >= 20


def test_commands_140_ms_apart_keep_the_wheels_turning(mona):
    # Just inside the watchdog: the wheels never stop between commands
    for _ in range(6):
        mona.command(-400, 400)
        mona.run(140)
    assert all(state[1] == pwm(400) for state in mona.wheels[2:]), mona.wheels


@pytest.mark.parametrize('seed', [22, 23, 24, 25])
def test_the_firmware_resynchronises_after_garbage(mona, seed):
    # Garbage, start bytes among it, between valid frames: every valid command is applied
    rng = random.Random(seed)
    stream = b''
    for seq in range(1, 21):
        garbage = bytes(rng.choice([0xA5, rng.randrange(256)]) for _ in range(rng.randrange(12)))
        frame = Frame(1, seq, mona.nonce, COMMAND, Command(seq * 40, -seq * 40).encode())
        stream += garbage + frame.encode()
    # a final valid frame flushes any fake start still waiting for its bytes
    stream += Frame(1, 21, mona.nonce, COMMAND, Command(-250, 250).encode()).encode()
    mona.send(stream)
    mona.run(200)
    assert mona.reports()[-1].ack == 21
    assert mona.outputs[:4] == (pwm(-250), 1, pwm(250), 0)
    applied = {state[1] for state in mona.wheels}
    assert {pwm(seq * 40) for seq in range(1, 21)} <= applied


def test_back_to_back_commands_are_all_applied_without_overrun(mona):
    # 60 frames with no gap (900 bytes, 170 ms of line) while telemetry goes out
    frames = b''.join(Frame(1, seq, mona.nonce, COMMAND, Command(seq, seq).encode()).encode()
                      for seq in range(1, 61))
    mona.send(frames)
    mona.run(250)
    last = mona.reports()[-1]
    assert (last.ack, last.rx_rejected) == (60, 0)
    lefts = [state[1] for state in mona.wheels[1:]]
    assert lefts == sorted(lefts) and lefts[-1] == pwm(60)
