"""Hardware in the loop: the driver node against three Mona firmwares in simavr (the images
one would flash), an emulated arena and tracker (``driver_hil``), the unchanged controller
nodes (one process per Mona, scripts/swarm.sh --role controllers) and the metrics node and
supervisor (--role supervision), for a whole realtime episode (10 s; 30 s with faults)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
import yaml

from swarm_metrics.bags.completeness import check_bag
from swarm_metrics.bags.reader import read_episode_bag

from harness import REPO

pytestmark = pytest.mark.ros

VENV_BIN = REPO / '.venv' / 'bin'
TOOLS = ('avr-gcc', 'make', 'cc')
ROBOTS = 3
#: Realtime seconds of an episode: the robots on the small arena first meet and clean
#: within 2-3 s, so 10 s show cleaning, travel and the link with room for a slow start.
DURATION = 10
#: With faults: frames are lost and duplicated at random (5 % each), and 30 s (~600
#: telemetry frames per robot) keep every robot's counts within 2.5-10 % in 99.5 % of runs
#: (20 s: ~97 %); the faults themselves are over 21 s after the announcement.
FAULTS_DURATION = 30


def needs_firmware_tools() -> None:
    missing = [tool for tool in TOOLS if shutil.which(tool) is None]
    if missing or not Path('/usr/include/simavr/sim_avr.h').exists():
        pytest.skip(f'hardware in the loop needs {missing or "simavr"}: make firmware-tools')


def small_arena(tmp_path: Path, duration: float) -> Path:
    """The shipped parameter file on a 0.6 m arena, so three robots meet within seconds."""
    document = yaml.safe_load((REPO / 'ros_ws/config/mona_swarm.yaml').read_text())
    parameters = document['/**']['ros__parameters']
    parameters['world']['arena_side'] = 0.6
    parameters['world']['cue_diameter'] = 0.6
    parameters['episode'].update(population=ROBOTS, duration=float(duration))
    path = tmp_path / 'hil.yaml'
    path.write_text(yaml.safe_dump(document))
    return path


def run_hil(processes, ros_env, tmp_path: Path, hil_options: Sequence[str] = (),
            driver_options: Sequence[str] = (), duration: float = DURATION) -> dict:
    """Start the harness, the controllers and the supervision; wait for the run's end."""
    needs_firmware_tools()
    params = small_arena(tmp_path, duration)
    domain = ros_env['ROS_DOMAIN_ID']
    hil = processes.spawn([str(VENV_BIN / 'driver_hil'), '--robots', str(ROBOTS),
                           '--params-file', str(params), '--out', str(tmp_path / 'hil'),
                           *hil_options, '--', '-p', 'recorders:=metrics', *driver_options],
                          'hil')
    swarm = str(REPO / 'scripts' / 'swarm.sh')
    controllers = processes.spawn([swarm, '--role', 'controllers', '--robots', '0-2',
                                   '--domain', domain, '--population', str(ROBOTS),
                                   '--config', str(params), '--out', str(tmp_path / 'ctl')],
                                  'controllers')
    started = time.monotonic()
    supervision = processes.spawn([swarm, '--role', 'supervision', '--domain', domain,
                                   '--population', str(ROBOTS), '--duration', str(duration),
                                   '--mode', 'realtime', '--config', str(params), '--out',
                                   str(tmp_path / 'run')], 'supervision')
    try:
        assert supervision.wait(timeout=150) == 0, processes.log('supervision')
        assert hil.wait(timeout=30) == 0, processes.log('hil')
        assert controllers.wait(timeout=30) == 0, processes.log('controllers')
    except subprocess.TimeoutExpired:
        pytest.fail('the run did not end: ' + processes.log('supervision')[-2000:])
    wall = time.monotonic() - started
    return {'run': tmp_path / 'run', 'hil': tmp_path / 'hil', 'wall': wall}


def firmware_seconds(processes) -> float:
    """How long the firmwares ran (simulated), from the harness's last line: on a loaded
    machine they lag the wall clock, and they send telemetry at 20 Hz of their own time."""
    return firmware_run(processes)[0]


def firmware_run(processes) -> tuple[float, float]:
    """(simulated seconds the firmwares ran, wall seconds the harness ran)."""
    found = re.search(r'the firmwares ran ([0-9.]+) s in ([0-9.]+) s', processes.log('hil'))
    assert found, processes.log('hil')[-2000:]
    return float(found.group(1)), float(found.group(2))


def unsent_while_silent(processes) -> list[int]:
    """The telemetry frames each robot's firmware made while its radio was silent."""
    found = re.search(r'frames unsent while silent, per robot: ([0-9 ]+)', processes.log('hil'))
    assert found, processes.log('hil')[-2000:]
    return [int(n) for n in found.group(1).split()]


def meets(poses: np.ndarray, robot: np.ndarray, reach: float) -> bool:
    """Whether a robot at pose ``robot`` has another one of ``poses`` within ``reach``."""
    distances = np.linalg.norm(poses[:, :2] - robot[:2], axis=1)
    return bool(((distances > 1e-9) & (distances <= reach)).any())


def test_a_whole_episode_with_three_simulated_firmwares(processes, ros_env, tmp_path):
    result = run_hil(processes, ros_env, tmp_path)
    run = json.loads((result['run'] / 'run.json').read_text())
    (episode,) = run['episodes']
    assert episode['records']['metrics']['complete'], episode['records']
    assert episode['steps'] == round(DURATION / 0.032 + 0.5)  # 313 steps of 32 ms
    bag = read_episode_bag(Path(episode['records']['metrics']['path']))
    _, findings = check_bag(bag)
    assert findings == [], findings
    # Robots that meet clean: cleaning robots had another robot within reach (two radii, the
    # IR range and the tracker margin) at the pose sample of that second, at least half of
    # them (a waiting robot goes on cleaning after the robot it met has moved on).
    assert len(bag.cleaning) >= 1, f'nobody cleaned in {DURATION} s on a 0.6 m arena'
    samples = dict(bag.poses)
    reach = 2 * 0.04 + 0.03 + 0.02
    near = [meets(samples[time_ns], robot, reach) for time_ns, cleaners in bag.cleaning
            if time_ns in samples for robot in cleaners]
    assert sum(near) >= 1 and sum(near) >= 0.5 * len(near), near
    final_cue, initial_cue = bag.cue_maps[-1][1], bag.cue_maps[0][1]
    assert final_cue.sum() < initial_cue.sum()  # the cleaning acted on the virtual cue
    # The robots moved: the tracker (the bag's poses) saw them travel.
    first, last = bag.poses[0][1], bag.poses[-1][1]
    assert np.linalg.norm(last[:, :2] - first[:, :2], axis=1).max() > 0.05
    # The link: every robot's telemetry came, 20 Hz of the firmwares' own time (which lags
    # the wall clock on a loaded machine), none lost; the robots held at most a tenth of the
    # episode (at the start until the tracker is heard; a stall of the loaded machine).
    record = json.loads((result['hil'] / 'episode_0' / 'driver.json').read_text())
    sent = 20 * firmware_seconds(processes)
    for robot in record['robots']:
        assert 0.95 * sent - 10 <= robot['received'] <= sent + 10, (robot, sent)
        assert robot['lost'] == 0 and robot['reboots'] == 0, robot
        assert robot['held_steps'] <= 0.1 * episode['steps'], robot
    print(f'hil: {result["wall"]:.1f} s wall, {len(bag.cleaning)} cleaning events '
          f'({sum(near)} of {len(near)} cleaners near a robot), '
          f'misses {episode["misses"]}, telemetry {[r["received"] for r in record["robots"]]}; '
          + processes.log('hil').strip().splitlines()[-1])


FAULTS = ['--latency', '0.1', '--loss', '0.05', '--duplicate', '0.05',
          '--tracker-latency', '0.1', '--tracker-noise', '0.002',
          '--reboot', '0@10', '--silence', '1@12+3', '--dropout', '2@18+3',
          '--battery', '2@8=3300', '--seed', '5']


def absent_in_statuses(bag, robot: int) -> int:
    """How many of the bag's running statuses list ``robot`` absent."""
    return sum(robot in status.get('absent', ()) for _, status in bag.status
               if status.get('state') == 'running')


def test_faults_are_survived_counted_and_recorded(processes, ros_env, tmp_path):
    """100 ms of link latency each way, 5 % of frames lost and 5 % duplicated each way, a
    tracker 100 ms late with 2 mm of noise; robot 0 reboots, robot 1's radio is dead for
    3 s, the tracker loses robot 2 for 3 s and its battery sags to 3.3 V. The run completes
    with a complete record, and every fault is in driver.json and the bag's statuses."""
    # A loaded machine can stall the emulator for half a second (its firmwares then lag the
    # wall clock): judge silence and dropouts over 1 s, still well within the 3 s faults.
    result = run_hil(processes, ros_env, tmp_path, FAULTS,
                     ['-p', 'driver.silent_after:=1.0', '-p', 'driver.tracker_timeout:=1.0'],
                     FAULTS_DURATION)
    run = json.loads((result['run'] / 'run.json').read_text())
    (episode,) = run['episodes']
    assert episode['records']['metrics']['complete'], episode['records']
    bag = read_episode_bag(Path(episode['records']['metrics']['path']))
    _, findings = check_bag(bag)
    assert findings == [], findings
    record = json.loads((result['hil'] / 'episode_0' / 'driver.json').read_text())
    rows = record['robots']
    sent = 20 * firmware_seconds(processes)  # telemetry frames per robot
    for row in rows:  # 5 % lost and 5 % duplicated (each at least 2.5 % here)
        assert row['lost'] >= 0.025 * sent and 0.025 * sent <= row['duplicated'] <= 0.1 * sent
    assert rows[0]['lost'] <= 0.1 * sent and rows[2]['lost'] <= 0.1 * sent
    # Robot 1's 3 s (wall) of silence: every frame its firmware made meanwhile, as the
    # emulator counts them, is counted lost (a gap in the sequence numbers), on top of the
    # link's. (The firmware's pace against the wall clock varies on a loaded machine, and a
    # reboot loses frames too: comparing robot 1's losses with the others' was a coin toss.)
    unsent = unsent_while_silent(processes)
    assert unsent[0] == unsent[2] == 0 and unsent[1] >= 20 * 3 * 0.1, unsent
    assert rows[1]['lost'] >= unsent[1], (rows, unsent)
    assert rows[0]['reboots'] == 1 and rows[1]['reboots'] == rows[2]['reboots'] == 0
    assert rows[1]['silences'] >= 1 and rows[1]['held_steps'] >= 40, rows[1]
    assert rows[2]['dropouts'] >= 1 and rows[2]['held_steps'] >= 40, rows[2]
    # Robot 0 (only rebooted) is held less than the silent and the unseen one (on a loaded
    # machine an emulator stall holds every robot for a while: the faults come on top).
    assert rows[0]['held_steps'] < min(rows[1]['held_steps'], rows[2]['held_steps'])
    # The held robots are absent in the record (the bag's /world/status), the others not.
    assert absent_in_statuses(bag, 1) >= 1 and absent_in_statuses(bag, 2) >= 1
    # The sagging battery is read through the firmware's ADC and divider, counted once.
    assert rows[2]['low_battery'] == 1 and abs(rows[2]['battery_mv'] - 3300) <= 10, rows[2]
    assert rows[0]['low_battery'] == 0 and abs(rows[0]['battery_mv'] - 3900) <= 10, rows[0]
    log = (result['hil'] / 'driver_node.log').read_text()
    assert 'robot 2 battery low' in log
    assert 'robot 0 rebooted' in log and 'robot 1 silent' in log
    assert 'robot 2 lost by the tracker' in log
    counts = [(r['lost'], r['duplicated'], r['held_steps']) for r in rows]
    print(f'faults: {result["wall"]:.1f} s wall, (lost, duplicated, held) {counts}, '
          f'{len(bag.cleaning)} cleaning events; '
          + processes.log('hil').strip().splitlines()[-1])
