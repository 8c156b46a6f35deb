"""The output guard: a folder holding a record is refused without --overwrite and emptied
with it; empty, absent or record-free folders are taken as they are."""

from __future__ import annotations

import pytest

from swarm_supervisor.outputs.guard import RecordExists, claim_output, record_in


def test_absent_empty_and_plain_folders_are_free(tmp_path):
    assert claim_output(tmp_path / 'new', overwrite=False) == tmp_path / 'new'
    (tmp_path / 'plots').mkdir()
    (tmp_path / 'plots' / 'figure.png').write_bytes(b'png')
    assert record_in(tmp_path / 'plots') is None
    claim_output(tmp_path / 'plots', overwrite=False)
    assert (tmp_path / 'plots' / 'figure.png').exists()


@pytest.mark.parametrize('relative, what', [
    ('study.json', 'a study'), ('s1/episode.json', 'an episode'),
    ('run.json', 'a node-system run'), ('bag/metadata.yaml', 'a bag'), ('bag/x_0.mcap', 'a bag')])
def test_a_record_is_refused_and_left_alone(tmp_path, relative, what):
    marker = tmp_path / 'out' / relative
    marker.parent.mkdir(parents=True)
    marker.write_text('{}')
    with pytest.raises(RecordExists, match=f'already holds {what}.*--overwrite'):
        claim_output(tmp_path / 'out', overwrite=False)
    assert marker.read_text() == '{}'


def test_overwrite_replaces_the_folder_whole(tmp_path):
    (tmp_path / 'out' / 's1').mkdir(parents=True)
    (tmp_path / 'out' / 's1' / 'episode.json').write_text('{}')
    (tmp_path / 'out' / 'notes.txt').write_text('old')
    claim_output(tmp_path / 'out', overwrite=True)
    assert list((tmp_path / 'out').iterdir()) == []  # emptied; the folder stays, locked


def test_a_file_is_never_an_output_folder(tmp_path):
    (tmp_path / 'out').write_text('x')
    with pytest.raises(RecordExists, match='is a file'):
        claim_output(tmp_path / 'out', overwrite=True)


def test_a_folder_another_process_writes_is_refused_until_it_ends(tmp_path):
    import subprocess
    import sys

    from swarm_supervisor.outputs.lock import FolderBusy
    out = tmp_path / 'out'
    writer = subprocess.Popen(
        [sys.executable, '-c', 'import sys, time; from swarm_supervisor.outputs.lock import '
         f'hold; hold({str(out)!r}); print("held", flush=True); time.sleep(60)'],
        stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline() == 'held\n'
        with pytest.raises(FolderBusy, match=rf'--out {out} is being written by another '
                                             rf'process \(pid {writer.pid}: .*hold.*\)'):
            claim_output(out, overwrite=True)  # not even with --overwrite
        assert out.is_dir() and list(out.iterdir()) == []
    finally:
        writer.kill()
        writer.wait()
    assert claim_output(out, overwrite=False) == out  # the kernel let the lock go


def test_places_that_cannot_take_a_folder_are_refused_creating_nothing(tmp_path):
    from swarm_supervisor.outputs.location import OutputError, check_location
    (tmp_path / 'notes.txt').write_text('x')
    with pytest.raises(OutputError, match=r'lies under \S*notes\.txt, which is a file'):
        check_location(tmp_path / 'notes.txt' / 'a' / 'b')
    with pytest.raises(OutputError, match='on /proc, a proc file system'):
        check_location('/proc/mona')
    with pytest.raises(OutputError, match='on /sys, a sysfs file system'):
        check_location('/sys/mona', '--videos', kind='file')
    check_location(tmp_path / 'new' / 'deeper')
    assert sorted(p.name for p in tmp_path.iterdir()) == ['notes.txt']


def test_a_read_only_mount_is_refused(tmp_path, monkeypatch):
    # The mount table as the kernel writes it (/proc/self/mountinfo), with tmp_path mounted
    # read-only: the tests run as root, who can write anywhere else.
    from swarm_supervisor.outputs import location
    table = tmp_path / 'mountinfo'
    point = str(tmp_path).replace(' ', '\\040')
    table.write_text('22 1 8:1 / / rw,relatime shared:1 - ext4 /dev/sda1 rw\n'
                     f'40 22 0:5 / {point} ro,nosuid shared:9 - tmpfs tmpfs ro\n')
    monkeypatch.setattr(location, 'MOUNTS', table)
    with pytest.raises(location.OutputError, match='which is mounted read-only'):
        location.check_location(tmp_path / 'out')
    with pytest.raises(location.OutputError, match='which is mounted read-only'):
        location.check_location(tmp_path)
    location.check_location(tmp_path.parent / 'elsewhere')
