"""The study in batches: the same files for any batch size, batches that balance the workers,
and an interrupted batch that keeps its finished episodes."""

import pytest

from swarm_supervisor import outputs, study
from swarm_supervisor.config import load_config

TINY = {'populations': [3, 6], 'speeds': [0.04, 0.08], 'seeds': [1, 2, 3], 'duration': 12.0,
        'snapshot_times': [0.0, 4.0, 12.0], 'factors': {'sensing.ir_miss': [0.0, 0.1]}}
#: TINY with two seeds of 6 s: 16 episodes, still both populations and factor levels mixed
#: in a batch, for the test that runs the study three times.
SMALL = {**TINY, 'seeds': [1, 2], 'duration': 6.0, 'snapshot_times': [0.0, 2.0, 6.0]}
COMPARED = (outputs.METRICS_FILE, outputs.SNAPSHOTS_FILE, outputs.FINAL_PNG)


def episode_bytes(out):
    return {(folder.name, name): (folder / name).read_bytes()
            for folder in sorted((out / study.EPISODES_DIR).iterdir()) for name in COMPARED}


def test_any_batch_size_writes_the_same_files(tmp_path):
    config = load_config().replace(study=SMALL)
    runs = {}
    for size, jobs in ((1, 1), (3, 2), (64, 1)):  # batches of 1; of 3 and 2; all 16
        out = tmp_path / f'b{size}'
        study.run_study(config, out, jobs=jobs, batch_size=size, progress=False,
                        start_method='fork')
        runs[size] = ((out / study.TABLE_FILE).read_bytes(), episode_bytes(out))
        assert study.read_invocations(out)[-1]['batch_size'] == size
    assert len(runs[1][1]) == 16 * len(COMPARED)
    assert runs[3] == runs[1]
    assert runs[64] == runs[1]


def test_batches_are_balanced_and_never_mix_step_periods():
    config = load_config().replace(study=TINY)
    tasks = [study.EpisodeTask(study.episode_config(config, spec), (), spec.name)
             for spec in study.design(config)]
    batches = study.make_batches(tasks, batch_size=5, jobs=2)
    assert [len(b) for b in batches] == [5, 5, 5, 5, 4]
    assert sorted(t.folder for b in batches for t in b) == sorted(t.folder for t in tasks)
    # Few episodes: every worker still gets a batch.
    assert [len(b) for b in study.make_batches(tasks[:4], batch_size=16, jobs=2)] == [2, 2]
    slow = load_config().replace(world={'step_period': 0.05}, episode={'population': 3})
    mixed = study.make_batches(tasks[:3] + [study.EpisodeTask(slow, (), 'slow')], batch_size=16,
                               jobs=1)
    assert sorted(len(b) for b in mixed) == [1, 3]


def test_an_interrupted_batch_keeps_its_finished_episodes(tmp_path, monkeypatch):
    config = load_config()
    short = config.replace(episode={'population': 3, 'duration': 3.0})
    long = config.replace(episode={'population': 3, 'duration': 6.0, 'seed': 2})
    written = outputs.write_episode

    def write(result, folder, **kwargs):
        if result.config.episode.duration > 5:
            raise KeyboardInterrupt  # stands for a kill while the long episode runs on
        return written(result, folder, **kwargs)

    monkeypatch.setattr(outputs, 'write_episode', write)
    with pytest.raises(KeyboardInterrupt):
        study.run_and_write([study.EpisodeTask(long, (0.0,), str(tmp_path / 'long')),
                             study.EpisodeTask(short, (0.0,), str(tmp_path / 'short'))])
    assert outputs.episode_complete(tmp_path / 'short')
    assert not outputs.episode_complete(tmp_path / 'long')


def test_run_with_several_seeds_writes_each_as_alone(tmp_path):
    from swarm_supervisor.cli import main

    common = ['--population', '4', '--duration', '6', '--speed', '4']
    assert main(['run', *common, '--seed', '3', '7', '--out',
                 str(tmp_path / 'many')]) == 0
    assert main(['run', *common, '--seed', '7', '--out', str(tmp_path / 'one')]) == 0
    for name in COMPARED:
        assert (tmp_path / 'many' / 's7' / name).read_bytes() == \
            (tmp_path / 'one' / name).read_bytes()
    assert outputs.episode_complete(tmp_path / 'many' / 's3')


def test_an_episode_without_its_picture_is_pending_only_where_pictures_are_asked(tmp_path):
    # A calibration's screening writes its episodes without the final cue map (they are
    # scored and deleted); a study that keeps them runs any such episode again, drawn.
    config = load_config().replace(study={**SMALL, 'populations': [3], 'speeds': [0.08],
                                          'seeds': [1], 'factors': {}})
    _, folders, pending = study.plan(config, tmp_path, picture=False)
    assert len(pending) == 1 and not pending[0].picture
    study.run_and_write(pending)
    (folder,) = folders.values()
    assert outputs.episode_complete(folder) and not (folder / outputs.FINAL_PNG).exists()
    assert study.plan(config, tmp_path, picture=False)[2] == []
    (again,) = study.plan(config, tmp_path)[2]
    assert again.picture
    study.run_and_write([again])
    assert (folder / outputs.FINAL_PNG).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    assert study.plan(config, tmp_path)[2] == []
