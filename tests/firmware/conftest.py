"""The firmware in simavr: build firmware/mona (mona.elf) and firmware/sim (monasim) once,
and give each test a fresh simulated Mona (``mona``) to talk to in simulated time.

Without the tools (``make firmware-tools`` installs them) the tests skip, naming what is
missing and the command that installs it (a failure of the run under CI=true).
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from mona_controller.link.frame import Decoder, Frame
from mona_controller.link.payloads import COMMAND, TELEMETRY, Command, Telemetry
from swarm_world.driver.firmware import make

REPO = Path(__file__).resolve().parents[2]
FIRMWARE = REPO / 'firmware'
CYCLES_PER_MS = 8000
#: What building needs, and the Debian package that has it.
TOOLS = {'avr-gcc': 'gcc-avr', 'avr-objcopy': 'binutils-avr', 'cc': 'gcc', 'make': 'make'}
FILES = {Path('/usr/lib/avr/include/avr/io.h'): 'avr-libc',
         Path('/usr/include/simavr/sim_avr.h'): 'libsimavr-dev',
         Path('/usr/include/libelf.h'): 'libelf-dev'}


def missing_tools() -> list[str]:
    """What the firmware tests lack on this machine (tool or file, and its package)."""
    missing = [f'{tool} ({package})' for tool, package in TOOLS.items()
               if shutil.which(tool) is None]
    missing += [f'{path} ({package})' for path, package in FILES.items() if not path.exists()]
    return missing


@pytest.fixture(scope='session')
def monasim() -> tuple[Path, Path]:
    """(firmware image, host program), built from the tree."""
    missing = missing_tools()
    if missing:
        pytest.skip(f'firmware tests need {", ".join(missing)}: make firmware-tools '
                    'installs them (as root)')
    for folder in ('mona', 'sim'):
        make(FIRMWARE / folder)
    return FIRMWARE / 'mona' / 'mona.elf', FIRMWARE / 'sim' / 'monasim'


@dataclass
class Mona:
    """One simulated Mona: send it frames, run it, read its wheels and telemetry."""

    process: subprocess.Popen[str]
    robot: int = 1
    nonce: int = 0x4242  # the host's boot nonce on its commands
    seq: int = 0
    #: (cycle, pwm_left, dir_left, pwm_right, dir_right, cleaner) at each change
    wheels: list[tuple[int, ...]] = field(default_factory=list)
    #: (cycle the frame's last byte left the UART, frame)
    telemetry: list[tuple[int, Frame]] = field(default_factory=list)
    #: cycles at which the host's queued bytes were all delivered
    delivered: list[int] = field(default_factory=list)
    decoder: Decoder = field(default_factory=Decoder)
    cycle: int = 0

    def _command(self, line: str) -> None:
        assert self.process.stdin is not None and self.process.stdout is not None
        self.process.stdin.write(line + '\n')
        self.process.stdin.flush()
        for reply in self.process.stdout:
            kind, _, rest = reply.partition(' ')
            words = rest.split()
            if kind == 'T':
                self.cycle = int(words[0])
                return
            if kind == 'W':
                self.wheels.append(tuple(int(w) for w in words))
            elif kind == 'U':
                for frame in self.decoder.feed(bytes.fromhex(words[1])):
                    self.telemetry.append((int(words[0]), frame))
            elif kind == 'R':
                self.delivered.append(int(words[0]))
            elif kind == 'E':
                raise AssertionError(f'the AVR stopped: {reply}')
        raise AssertionError(f'monasim ended (exit {self.process.wait()})')

    def send(self, data: bytes) -> None:
        """Queue raw bytes for the firmware's UART."""
        self._command(f'send {data.hex()}')

    def command(self, left: int, right: int, cleaner: bool = False, robot: int | None = None,
                seq: int | None = None) -> bytes:
        """Send a wheel command frame (the next sequence number unless given); its bytes."""
        if seq is None:
            self.seq += 1
            seq = self.seq
        frame = Frame(self.robot if robot is None else robot, seq, self.nonce, COMMAND,
                      Command(left, right, cleaner).encode())
        self.send(frame.encode())
        return frame.encode()

    def run(self, ms: float) -> None:
        """Run the AVR for ``ms`` milliseconds of simulated time."""
        self._command(f'run {round(ms * 1000)}')

    def adc(self, channel: int, millivolts: int) -> None:
        """Set the voltage on an ADC input."""
        self._command(f'adc {channel} {millivolts}')

    def encoder(self, side: str, edges: int, period_us: int = 500) -> None:
        """Toggle an encoder input ``edges`` times."""
        self._command(f'enc {side} {edges} {period_us}')

    def reset(self) -> None:
        """Reset the AVR (EEPROM kept)."""
        self._command('reset')

    @property
    def outputs(self) -> tuple[int, ...]:
        """The wheel outputs now: (pwm_left, dir_left, pwm_right, dir_right, cleaner)."""
        return self.wheels[-1][1:]

    def reports(self) -> list[Telemetry]:
        """Every telemetry payload received so far."""
        return [Telemetry.decode(frame.payload) for _, frame in self.telemetry
                if frame.kind == TELEMETRY]


@pytest.fixture
def mona(monasim: tuple[Path, Path]) -> Iterator[Mona]:
    """A fresh simulated Mona, booted (its first telemetry sent)."""
    elf, host = monasim
    process = subprocess.Popen([str(host), str(elf)], stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, text=True)
    robot = Mona(process)
    try:
        robot.run(60)
        yield robot
    finally:
        if process.poll() is None:
            process.stdin.close()  # type: ignore[union-attr]
            process.wait(timeout=10)
