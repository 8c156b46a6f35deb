"""The launcher's scan of the Fast DDS /dev/shm files its nodes hold
(swarm_supervisor.system.processes): it finds a file a process holds open, and a stop
request cuts it short (a signal to the launcher must not wait for a scan of dozens of
processes on a crowded machine)."""

from __future__ import annotations

import os
import uuid

from swarm_supervisor.system.processes import SHM, groups_shm, mapped_shm


def test_a_held_file_is_found_and_a_stop_request_cuts_the_scan_short():
    name = f'fastrtps_test_{uuid.uuid4().hex}'
    path = SHM / name
    with open(path, 'w'):  # this process holds it open, as a node holds its segment
        try:
            me = [os.getpid()]
            assert name in mapped_shm(me)
            assert name in groups_shm([os.getpgid(0)])
            assert mapped_shm(me, stop=lambda: True) == set()
            assert groups_shm([os.getpgid(0)], stop=lambda: True) == set()
        finally:
            path.unlink()
