"""Transports of link frames behind one interface: a serial line (pyserial) and UDP.

A transport moves bytes; :class:`.frame.Decoder` finds the frames in them. A serial line is a
stream (a frame may arrive in pieces); a UDP datagram holds whole frames, so the receiver
flushes its decoder after each one (:attr:`Transport.datagrams`).
"""

from __future__ import annotations

import select
import socket
from abc import ABC, abstractmethod

import serial

#: The firmware's baud rate (docs/link.md, "Timing").
BAUD = 57600


class Transport(ABC):
    """Sends and receives raw bytes of link frames."""

    #: Whether each :meth:`receive` returns whole datagrams (flush the decoder after each).
    datagrams = False

    @abstractmethod
    def send(self, data: bytes) -> None:
        """Send ``data`` (one or more encoded frames)."""

    @abstractmethod
    def receive(self, timeout: float) -> bytes:
        """The bytes that arrived within ``timeout`` seconds (b'' if none)."""

    @abstractmethod
    def close(self) -> None:
        """Release the port or socket."""

    def __enter__(self) -> Transport:
        """The transport itself (closed on exit)."""
        return self

    def __exit__(self, *exc: object) -> None:
        """Close the transport."""
        self.close()


class SerialTransport(Transport):
    """A serial port, or any pyserial URL (``loop://`` for tests, ``rfc2217://``...)."""

    def __init__(self, port: str, baud: int = BAUD) -> None:
        self._port = serial.serial_for_url(port, baudrate=baud, timeout=0)

    def send(self, data: bytes) -> None:
        """Write ``data`` to the line."""
        self._port.write(data)

    def receive(self, timeout: float) -> bytes:
        """Whatever the line delivered within ``timeout`` (returns early once bytes came)."""
        self._port.timeout = timeout
        first = self._port.read(1)
        if not first:
            return b''
        data: bytes = first + self._port.read(self._port.in_waiting)
        return data

    def close(self) -> None:
        """Close the port."""
        self._port.close()


class UdpTransport(Transport):
    """UDP datagrams between ``local`` (bound) and ``remote`` (host, port)."""

    datagrams = True
    #: Larger than any datagram of frames the link sends.
    MAX_DATAGRAM = 2048

    def __init__(self, local: tuple[str, int], remote: tuple[str, int]) -> None:
        self._socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._socket.bind(local)
        self._socket.setblocking(False)
        self.remote = remote

    @property
    def address(self) -> tuple[str, int]:
        """The bound (host, port) (port 0 in ``local`` picks a free one)."""
        host, port = self._socket.getsockname()[:2]
        return host, port

    def send(self, data: bytes) -> None:
        """Send ``data`` as one datagram to the remote end."""
        self._socket.sendto(data, self.remote)

    def receive(self, timeout: float) -> bytes:
        """One datagram that arrived within ``timeout`` (b'' if none)."""
        ready, _, _ = select.select([self._socket], [], [], timeout)
        if not ready:
            return b''
        data, _ = self._socket.recvfrom(self.MAX_DATAGRAM)
        return data

    def close(self) -> None:
        """Close the socket."""
        self._socket.close()
