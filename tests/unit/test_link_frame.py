"""The link's frame codec: round-trips, and every rejected frame counted by its reason."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mona_controller.link.crc import CHECK, crc16
from mona_controller.link.frame import (
    BAD_CRC,
    BAD_LENGTH,
    BAD_START,
    BAD_TYPE,
    START,
    TRUNCATED,
    Decoder,
    Frame,
    FrameError,
    check,
)
from mona_controller.link.payloads import (
    COMMAND,
    FULL_SPEED,
    TELEMETRY,
    Command,
    PayloadError,
    Telemetry,
)

u16 = st.integers(0, 0xFFFF)
commands = st.builds(Command, st.integers(-FULL_SPEED, FULL_SPEED),
                     st.integers(-FULL_SPEED, FULL_SPEED), st.booleans())
telemetries = st.builds(Telemetry, st.tuples(*[st.integers(0, 1023)] * 5), u16, u16, u16, u16,
                        st.integers(0, 255), st.integers(0, 255))


def command_frame(seq: int = 7, nonce: int = 3, left: int = 500, right: int = -20) -> Frame:
    return Frame(2, seq, nonce, COMMAND, Command(left, right, True).encode())


def test_the_crc_is_ccitt_false():
    # The catalogue's check value for CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF)
    assert crc16(b'123456789') == CHECK == 0x29B1


def test_a_frame_is_laid_out_as_documented():
    data = Frame(0x12, 0x0304, 0x0506, COMMAND, Command(1, -1).encode()).encode()
    assert data[:8] == bytes([START, 5, 0x12, 0x04, 0x03, 0x06, 0x05, COMMAND])
    assert data[8:13] == bytes([1, 0, 0xFF, 0xFF, 0])
    assert int.from_bytes(data[13:], 'little') == crc16(data[1:13])


@given(robot=st.integers(0, 255), seq=u16, nonce=u16, command=commands)
def test_commands_round_trip(robot, seq, nonce, command):
    frame = Frame(robot, seq, nonce, COMMAND, command.encode())
    decoded = check(frame.encode())
    assert decoded == frame
    assert Command.decode(decoded.payload) == command


@given(seq=u16, nonce=u16, telemetry=telemetries)
def test_telemetry_round_trips(seq, nonce, telemetry):
    frame = Frame(4, seq, nonce, TELEMETRY, telemetry.encode())
    assert Telemetry.decode(check(frame.encode()).payload) == telemetry


@given(frames=st.lists(commands.map(lambda c: Frame(1, 0, 0, COMMAND, c.encode())),
                       max_size=8),
       garbage=st.lists(st.binary(max_size=12), min_size=9, max_size=9),
       cut=st.integers(1, 40))
def test_the_stream_decoder_finds_every_frame_between_garbage(frames, garbage, cut):
    # Garbage without a start byte cannot hide a frame; fed in arbitrary pieces
    garbage = [g.replace(bytes([START]), b'') for g in garbage]
    stream = b''.join(g + f.encode() for g, f in zip(garbage, frames)) + garbage[-1]
    decoder = Decoder()
    found = []
    for at in range(0, len(stream), cut):
        found.extend(decoder.feed(stream[at:at + cut]))
    assert found == frames
    assert sum(decoder.rejected.values()) == 0
    assert decoder.garbage == sum(map(len, garbage[:len(frames)])) + len(garbage[-1])


@given(index=st.integers(1, 14), flip=st.integers(1, 255))
def test_a_corrupted_byte_is_rejected_and_counted(index, flip):
    good = command_frame(seq=1).encode()
    bad = bytearray(command_frame(seq=2).encode())
    bad[index] ^= flip
    decoder = Decoder()
    found = list(decoder.feed(bytes(bad) + good)) + decoder.flush()
    # The next good frame is never lost, whatever the corrupted byte did to the length
    assert found[-1] == command_frame(seq=1)
    assert all(frame == command_frame(seq=1) or frame.seq == 2 for frame in found)
    assert command_frame(seq=2) not in found
    assert sum(decoder.rejected.values()) >= 1


def test_a_wrong_crc_is_rejected_as_bad_crc():
    bad = bytearray(command_frame().encode())
    bad[-1] ^= 0x01
    decoder = Decoder()
    assert list(decoder.feed(bytes(bad))) == []
    assert decoder.rejected[BAD_CRC] == 1
    with pytest.raises(FrameError) as error:
        check(bytes(bad))
    assert error.value.reason == BAD_CRC


def test_a_frame_cut_short_by_the_next_is_truncated():
    first = command_frame(seq=1).encode()
    second = command_frame(seq=2).encode()
    decoder = Decoder()
    found = list(decoder.feed(first[:9] + second))
    assert found == [command_frame(seq=2)]
    assert decoder.rejected[TRUNCATED] == 1 and decoder.rejected[BAD_CRC] == 0


def test_a_partial_frame_at_the_end_of_a_datagram_is_truncated():
    decoder = Decoder()
    assert list(decoder.feed(command_frame().encode()[:-3])) == []
    assert decoder.flush() == []
    assert decoder.rejected[TRUNCATED] == 1
    with pytest.raises(FrameError) as error:
        check(command_frame().encode()[:-3])
    assert error.value.reason == TRUNCATED


def test_a_length_beyond_the_largest_payload_is_rejected_as_bad_length():
    bad = bytes([START, 200, 1, 0, 0, 0, 0, COMMAND]) + bytes(10)
    decoder = Decoder()
    assert list(decoder.feed(bad + command_frame().encode())) == [command_frame()]
    assert decoder.rejected[BAD_LENGTH] == 1


def test_a_valid_crc_on_a_payload_of_the_wrong_size_is_bad_length():
    frame = Frame(1, 0, 0, COMMAND, b'\x00\x00\x00')
    decoder = Decoder()
    assert list(decoder.feed(frame.encode())) == []
    assert decoder.rejected[BAD_LENGTH] == 1


def test_an_unknown_payload_type_is_rejected():
    decoder = Decoder()
    assert list(decoder.feed(Frame(1, 0, 0, 0x42, b'').encode())) == []
    assert decoder.rejected[BAD_TYPE] == 1


def test_payload_values_are_checked():
    with pytest.raises(PayloadError):
        Command(FULL_SPEED + 1, 0).encode()
    with pytest.raises(PayloadError):
        Telemetry.decode(Telemetry((1024, 0, 0, 0, 0), 0, 0, 0, 0, 0, 0).encode())
    with pytest.raises(PayloadError):
        Command.decode(b'\x00')


@given(frames=st.lists(commands.map(lambda c: Frame(1, 0, 0, COMMAND, c.encode())),
                       min_size=1, max_size=6),
       garbage=st.lists(st.lists(st.sampled_from([START, 0x00, 0x05, 0x14, 0x20, 0xFF]) |
                                 st.integers(0, 255), max_size=14).map(bytes),
                        min_size=7, max_size=7),
       cut=st.integers(1, 40))
def test_start_bytes_in_the_garbage_never_hide_a_frame(frames, garbage, cut):
    # A fake start byte whose length spans the next real frame: resynchronised inside it
    stream = b''.join(g + f.encode() for g, f in zip(garbage, frames)) + garbage[-1]
    decoder = Decoder()
    found = []
    for at in range(0, len(stream), cut):
        found.extend(decoder.feed(stream[at:at + cut]))
    found.extend(decoder.flush())
    assert found == frames


def test_check_names_what_is_wrong_with_a_datagram():
    good = command_frame().encode()
    for data, reason in [(b'\x00' + good[1:], BAD_START), (good[:5], TRUNCATED),
                         (good + b'\x00', BAD_LENGTH)]:
        with pytest.raises(FrameError) as error:
            check(data)
        assert error.value.reason == reason
