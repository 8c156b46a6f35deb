"""The transports: a serial loop (pyserial's loop://) and UDP on the loopback interface."""

from __future__ import annotations

from mona_controller.link.frame import Decoder, Frame
from mona_controller.link.payloads import COMMAND, Command
from mona_controller.link.transport import SerialTransport, UdpTransport


def frames(n: int) -> list[Frame]:
    return [Frame(3, seq, 1, COMMAND, Command(seq, -seq).encode()) for seq in range(n)]


def test_frames_cross_a_serial_line():
    sent = frames(5)
    decoder = Decoder()
    with SerialTransport('loop://') as line:
        line.send(b''.join(frame.encode() for frame in sent))
        found: list[Frame] = []
        while len(found) < len(sent) and (data := line.receive(0.5)):
            found.extend(decoder.feed(data))
    assert found == sent


def test_frames_cross_udp_one_datagram_each():
    sent = frames(3)
    with UdpTransport(('127.0.0.1', 0), ('127.0.0.1', 9)) as robot:
        with UdpTransport(('127.0.0.1', 0), robot.address) as host:
            robot.remote = host.address
            decoder = Decoder()
            for frame in sent:
                host.send(frame.encode())
            found: list[Frame] = []
            for frame in sent:
                # One receive is one whole datagram: exactly one frame's bytes, so a decoder
                # may be flushed after each (what Transport.datagrams promises)
                datagram = robot.receive(1.0)
                assert robot.datagrams and datagram == frame.encode()
                found.extend(decoder.feed(datagram))
                found.extend(decoder.flush())
            assert robot.receive(0.01) == b''
    assert found == sent
    assert sum(decoder.rejected.values()) == 0
