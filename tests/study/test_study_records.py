"""study --bag and --videos: each episode's bag (the node system's record) beside its
outputs, one video per design cell, and resume that runs again an episode lacking its bag."""

from __future__ import annotations

import json
from pathlib import Path

import imageio_ffmpeg

from swarm_metrics.bags.reader import read_episode_bag
from swarm_supervisor import outputs, study
from swarm_supervisor.cli import main
from swarm_supervisor.config import load_config, write_ros_yaml

DESIGN = {'populations': [4], 'speeds': [0.08], 'seeds': [1, 2], 'duration': 12.0,
          'snapshot_times': [0.0, 12.0], 'factors': {'mona.ir_range': [0.02, 0.05]}}


def test_bags_videos_and_resume(tmp_path: Path):
    config = tmp_path / 'design.yaml'
    write_ros_yaml(load_config().replace(study=DESIGN), config)
    out = tmp_path / 'out'
    # First without bags (the study alone, in this process: its analysis is not looked at):
    # then --videos must run every episode again, for its bag.
    study.run_study(load_config(config), out, progress=False, start_method='fork')
    assert main(['study', '--out', str(out), '--config', str(config), '--videos']) == 0
    assert study.read_invocations(out)[-1]['ran'] == 4
    for folder in sorted((out / study.EPISODES_DIR).iterdir()):
        record = json.loads((folder / outputs.EPISODE_FILE).read_text())
        assert record['bag'] == study.BAG_DIR
        bag = read_episode_bag(folder / study.BAG_DIR)
        times, values = bag.metric('mean_cue')
        metrics = outputs.read_metrics_csv(folder / outputs.METRICS_FILE)
        assert list(values) == list(metrics['mean_cue'])  # the bag holds the episode's record
    videos = sorted((out / study.VIDEOS_DIR).iterdir())
    assert [path.name for path in videos] == ['N4_v8_s1_mona.ir_range=0.02.mp4',
                                              'N4_v8_s1_mona.ir_range=0.05.mp4']
    # 12 s at the default 100x and 25 fps: 3 frames.
    assert imageio_ffmpeg.count_frames_and_secs(str(videos[0]))[0] == 3
    study.run_study(load_config(config), out, videos=True, progress=False)
    assert study.read_invocations(out)[-1]['ran'] == 0
