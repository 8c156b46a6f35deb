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
