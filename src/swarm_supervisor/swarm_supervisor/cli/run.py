"""``mona-swarm run``: one episode with the embedded runner, written to a folder.

With ``--bag`` the folder also gets the bag the metrics node would have recorded
(:mod:`swarm_supervisor.outputs.bag`), so ``analyze``, ``replay``, ``animate`` and Foxglove take
embedded episodes like the node system's.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, cast

from mona_controller.schema import ParameterError
from swarm_supervisor import exits
from swarm_supervisor.cli.arguments import bounded, deprecated_alias, speed_cm_s
from swarm_supervisor.media import DEFAULT_PORT
from swarm_supervisor.outputs.guard import claim_output
from swarm_supervisor.study import DEFAULT_BATCH_SIZE

if TYPE_CHECKING:
    from swarm_supervisor.config import SwarmConfig
    from swarm_supervisor.engine.runner import EpisodeObserver, EpisodeResult
    from swarm_supervisor.media.live import LiveServer, LiveView

# The engine, the live view (Foxglove), the bag writer and the pictures (matplotlib) are
# imported where an episode runs, not here: ``--help`` and a refused argument or parameter
# need none of them.

#: Wall seconds ``--wait-for-viewer`` waits for a viewer by default.
VIEWER_TIMEOUT = 600.0


def register(subparsers) -> None:
    """Add the ``run`` subcommand."""
    parser = subparsers.add_parser(
        'run', help='run one episode with the embedded runner',
        description='Run one episode in one process and write metrics.csv, episode.json, '
                    'snapshots.npz and a final cue-map PNG into --out; with --bag also its '
                    'rosbag2/MCAP record (--out/bag), as the metrics node writes it.')
    parser.add_argument('--population', type=int, metavar='N',
                        help='number of robots N (default: config)')
    parser.add_argument('--speed', type=speed_cm_s, metavar='CM_PER_S',
                        help='forward speed in cm/s, e.g. 8 or 4 (default: config, whose '
                             'controller.speed is in m/s); below 0.5 is refused as m/s')
    parser.add_argument('--seed', type=int, nargs='+',
                        help='episode seed (default: config); several seeds run as episodes '
                             'stepped together (the batched engine), each into DIR/s<seed>')
    parser.add_argument('--batch-size', type=bounded(int, 1), default=DEFAULT_BATCH_SIZE,
                        metavar='B', help='with several seeds: episodes stepped together at '
                        f'most (default {DEFAULT_BATCH_SIZE}); the outputs are the same for any')
    parser.add_argument('--duration', type=float, metavar='SECONDS',
                        help='simulated episode length (default: config)')
    parser.add_argument('--out', type=Path, required=True, metavar='DIR',
                        help='output folder (created); one holding a record is refused '
                             'unless --overwrite')
    parser.add_argument('--overwrite', action='store_true',
                        help='replace --out whole if it holds a record (a run, episode, study '
                             'or bag)')
    parser.add_argument('--config', type=Path, metavar='YAML',
                        help='ROS 2 parameter file (default: ros_ws/config/mona_swarm.yaml)')
    parser.add_argument('--bag', action='store_true',
                        help='also record the episode into DIR/bag (rosbag2, MCAP), the same '
                             "record the node system's metrics node writes (docs/bags.md)")
    parser.add_argument('--live', action='store_true',
                        help='serve the episode to Foxglove while it runs (WebSocket on '
                             'localhost, see --live-port; docs/running.md)')
    parser.add_argument('--live-port', type=bounded(int, 0, 65535), default=DEFAULT_PORT,
                        metavar='PORT', help=f'--live: the WebSocket port (default '
                                             f'{DEFAULT_PORT}; 0: any free one, printed)')
    deprecated_alias(parser, '--port', '--live-port')
    parser.add_argument('--linger', type=bounded(float, 0.0, 1e6), metavar='SECONDS',
                        help='--live: after the episode, keep serving its final state for '
                             'SECONDS (default: until Ctrl-C, which then exits 0; the outputs '
                             'are written before)')
    parser.add_argument('--wait-for-viewer', type=bounded(float, 0.0, 1e6), nargs='?',
                        const=VIEWER_TIMEOUT, metavar='SECONDS',
                        help='--live: hold the episode at t = 0 until a viewer (a Foxglove '
                             'client) has subscribed to the live view, so it sees the whole '
                             'episode however long it takes to connect; give up after SECONDS '
                             f'(default {VIEWER_TIMEOUT:g}) with exit status {exits.TIMEOUT}, '
                             'nothing written. The episode is the same bit for bit')
    parser.add_argument('--pace', type=bounded(float, 0.001, 1e6), metavar='X',
                        help='run at X times real time (e.g. 10: ten sim seconds per second), '
                             'to follow it live (default: as fast as possible)')
    parser.set_defaults(handler=run)


def _run(config: SwarmConfig, observers: list[EpisodeObserver]) -> EpisodeResult:
    """The episode, with a progress bar."""
    from tqdm import tqdm

    from swarm_supervisor.engine.runner import run_episode

    duration = config.episode.duration
    with tqdm(total=duration, unit='sim s', desc=f'N={config.episode.population}',
              disable=None, file=sys.stderr, bar_format='{l_bar}{bar}| {n:.0f}/{total:.0f} '
              'sim s [{elapsed}<{remaining}]') as bar:
        return run_episode(config, snapshot_times=config.study.snapshot_times + (duration,),
                           progress=lambda t: bar.update(t - bar.n), observers=observers)


def run(args: argparse.Namespace) -> int:
    """Run the episode (or the episodes of several seeds) and write its outputs."""
    configs = episode_configs(args)
    if len(configs) > 1:
        claim_output(args.out, overwrite=args.overwrite)
        return _run_seeds(args, configs)
    server = None
    if args.live:  # before --out is claimed: a busy port must not cost a record
        from swarm_supervisor.media.live import LiveServer, announce
        from swarm_supervisor.outputs.guard import check_output

        try:
            server = LiveServer(args.live_port)
        except RuntimeError as error:
            print(f'mona-swarm run: error: {error}', file=sys.stderr)
            return 2
    try:
        if server is not None:
            check_output(args.out, overwrite=args.overwrite)  # refused before the wait
            announce(server, 'mona-swarm run')
            if args.wait_for_viewer is not None and \
                    not wait_for_viewer(server, args.wait_for_viewer):
                return exits.TIMEOUT
        # Every check is done before this: a refused run leaves --out as it was.
        claim_output(args.out, overwrite=args.overwrite)
        return _run_one(args, configs[0], server)
    finally:
        if server is not None:
            server.stop()


def wait_for_viewer(server: LiveServer, seconds: float) -> bool:
    """Hold the episode's start until a client subscribes to the live view, ``seconds`` at
    most (each step of the episode is then served to it); whether one did (if not, the error
    is printed)."""
    print(f'mona-swarm run: waiting for a viewer on {server.url} (up to {seconds:g} s): the '
          'episode starts once a Foxglove client subscribes', file=sys.stderr, flush=True)
    if not server.wait_for_viewer(seconds):
        print(f'mona-swarm run: error: no viewer subscribed to the live view on {server.url} '
              f'in {seconds:g} s (--wait-for-viewer): the episode was not run, nothing was '
              'written', file=sys.stderr, flush=True)
        return False
    print('mona-swarm run: a viewer has subscribed; the episode starts', file=sys.stderr,
          flush=True)
    return True


def _run_one(args: argparse.Namespace, config: SwarmConfig, server: LiveServer | None
             ) -> int:
    """One episode into the claimed --out, served live to ``server`` if there is one."""
    from swarm_supervisor.engine.runner import Pacer
    from swarm_supervisor.media.live import LiveView
    from swarm_supervisor.outputs.bag import BagRecorder, RecordError
    from swarm_supervisor.outputs.episode_folder import write_episode

    observers: list[EpisodeObserver] = []
    recorder = None
    if args.bag:
        try:
            recorder = BagRecorder(args.out)
        except FileExistsError as error:
            print(f'mona-swarm run: error: {error}', file=sys.stderr)
            return 2
        observers.append(recorder)
    live = None
    if server is not None:
        live = LiveView(server, pace=args.pace)
        observers.append(live)
    elif args.pace is not None:
        observers.append(Pacer(args.pace))
    result = _run(config, observers)
    extra: dict[str, str] = {}
    if recorder is not None:
        try:
            extra['bag'] = str(recorder.check(result).path)
        except RecordError as error:
            print(f'mona-swarm run: error: {error}', file=sys.stderr)
            return 1
    out = write_episode(result, args.out, extra=extra)
    last = result.metrics[-1]
    print(f'{out}: N={config.episode.population} v={config.controller.speed * 100:g} cm/s '
          f'seed={config.episode.seed}: mean cue {last["mean_cue"]:.2f} '
          f'({last["mean_cue_fraction"]:.1%} of start) after {last["t"]:g} s; '
          f'{result.real_time_factor:.0f}x real time'
          + (f'; bag {extra["bag"]}' if extra else ''))
    if live is not None:
        linger(live, cast('LiveServer', server), args.linger)  # live: there is a server
    return 0


def linger(live: LiveView, server: LiveServer, seconds: float | None) -> None:
    """Serve the finished episode's final state for ``seconds`` (None: until Ctrl-C or
    SIGTERM); the outputs are complete already, so stopping loses nothing."""
    if seconds == 0:
        return
    until = 'Ctrl-C' if seconds is None else f'{seconds:g} s or Ctrl-C'
    print(f'mona-swarm run: the episode has ended; the live view on {server.url} keeps '
          f'serving its final state until {until}', file=sys.stderr, flush=True)
    stop = threading.Event()
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: stop.set())
    try:
        live.linger(seconds, stop)
    except KeyboardInterrupt:
        pass  # the way to end an endless linger: not a failure
    finally:
        signal.signal(signal.SIGTERM, previous)
    print('mona-swarm run: live view closed', file=sys.stderr, flush=True)


def episode_configs(args: argparse.Namespace) -> list[SwarmConfig]:
    """The configuration of each episode: the file's with the options applied, one per seed.

    Raises:
        ParameterError: a bad value (from the file or an option), a seed given twice, an
            empty arena, or --live/--pace with several seeds.
    """
    from swarm_supervisor.config import load_config
    from swarm_supervisor.engine.inputs import check_inputs

    seeds = args.seed or [None]
    repeated = sorted({seed for seed in seeds if seeds.count(seed) > 1})
    if repeated:  # two episodes would write one folder, DIR/s<seed>
        raise ParameterError(f'--seed {" ".join(map(str, seeds))} repeats seed '
                             f'{repeated[0]}: give each seed once')
    if len(seeds) > 1 and (args.live or args.pace is not None):
        raise ParameterError('--live and --pace take one seed')
    if args.linger is not None and not args.live:
        raise ParameterError('--linger is for --live: it keeps the live view up after the '
                             'episode')
    if args.wait_for_viewer is not None and not args.live:
        raise ParameterError('--wait-for-viewer is for --live: it holds the episode until a '
                             'viewer of the live view has subscribed')
    base = load_config(args.config)
    episode = {key: value for key, value in (('population', args.population),
                                              ('duration', args.duration))
               if value is not None}
    controller = {} if args.speed is None else {'speed': args.speed / 100}
    configs = [base.replace(episode={**episode, **({} if seed is None else {'seed': seed})},
                            controller=controller) for seed in seeds]
    population = configs[0].episode.population
    if population < 1:  # the metrics of an empty arena are undefined (NaN coherency)
        source = '--population' if args.population is not None else \
            f'{args.config or "the default configuration"}: episode.population'
        raise ParameterError(f'{source} = {population}: an episode needs at least one robot '
                             '(allowed [1, 100000])')
    check_inputs(configs[0])  # files, placement, metrics: before --out is touched
    return configs


def _run_seeds(args: argparse.Namespace, configs: list[SwarmConfig]) -> int:
    """Several seeds: batches of episodes stepped together, each written into DIR/s<seed> as
    soon as it is done (the same files as ``run --seed S --out DIR/s<seed>``)."""
    from swarm_supervisor.engine.runner import run_batch
    from swarm_supervisor.outputs.bag import BagRecorder, RecordError
    from swarm_supervisor.outputs.episode_folder import write_episode

    folders = [args.out / f's{seed}' for seed in args.seed]
    times = configs[0].study.snapshot_times + (configs[0].episode.duration,)
    status = 0
    for first in range(0, len(configs), args.batch_size):
        chunk = range(first, min(first + args.batch_size, len(configs)))
        recorders = []
        for k in chunk:
            try:
                recorders.append(BagRecorder(folders[k]) if args.bag else None)
            except FileExistsError as error:
                print(f'mona-swarm run: error: {error}', file=sys.stderr)
                return 2

        def finished(index: int, result: EpisodeResult, chunk=chunk, recorders=recorders
                     ) -> None:
            nonlocal status
            k, extra = chunk[index], {}
            if recorders[index] is not None:
                try:
                    extra['bag'] = str(recorders[index].check(result).path)
                except RecordError as error:
                    print(f'mona-swarm run: error: {error}', file=sys.stderr)
                    status = 1
                    return
            out = write_episode(result, folders[k], extra=extra)
            last = result.metrics[-1]
            print(f'{out}: seed={args.seed[k]}: mean cue {last["mean_cue"]:.2f} '
                  f'({last["mean_cue_fraction"]:.1%} of start) after {last["t"]:g} s; '
                  f'{result.real_time_factor:.0f}x real time per episode', flush=True)

        run_batch([configs[k] for k in chunk], snapshot_times=times,
                  observers=[[] if r is None else [r] for r in recorders], finished=finished)
    return status
