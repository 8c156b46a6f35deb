"""``mona-swarm animate``: a video (MP4 or GIF) of an episode from its bag, or a still (PNG)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from swarm_supervisor.cli.arguments import bounded
from swarm_supervisor.outputs.location import OutputError, check_location


def register(subparsers) -> None:
    """Add the ``animate`` subcommand."""
    parser = subparsers.add_parser(
        'animate', help='render a video (or a still) of an episode from its bag',
        description='Render the cue map being cleaned, the robots coloured by state '
                    '(follow, avoid, wait and clean, turn), the clock and the three metrics '
                    'into an MP4 or GIF, or one moment of it into a PNG, from an episode '
                    'folder holding bag/ (mona-swarm run --bag, scripts/swarm.sh) or a bag.')
    parser.add_argument('episode', type=Path, metavar='EPISODE_DIR_OR_BAG',
                        help='an episode folder with bag/, a bag directory or its .mcap')
    parser.add_argument('--out', type=Path, required=True, metavar='VIDEO',
                        help='the video to write: .mp4 (H.264) or .gif, or a still: .png; an '
                             'existing file is refused unless --overwrite')
    parser.add_argument('--overwrite', action='store_true',
                        help='replace an existing video')
    parser.add_argument('--speedup', type=bounded(float, 0.01, 1e6), default=100.0,
                        metavar='X', help='sim seconds per video second (default 100)')
    parser.add_argument('--fps', type=bounded(float, 1, 120), default=25.0, metavar='F',
                        help='frames per second (default 25)')
    parser.add_argument('--width', type=bounded(int, 160, 3840), metavar='PIXELS',
                        help='frame width (default 1024 for MP4, 640 for GIF, 1280 for '
                             'PNG); height 9/16')
    parser.add_argument('--at', type=bounded(float, 0, 1e9), metavar='SECONDS',
                        help="a still's sim time (only with a .png --out; default: the end)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Render the video; exit 2 for a bad input, 0 once the video is whole."""
    # Here, not at the top: ``--help`` and a refused argument need no bag reader or video.
    from tqdm import tqdm

    from swarm_metrics.bags.scan import BagError
    from swarm_supervisor.media.video import AnimateError, animate

    refused = _refused_output(args.out, overwrite=args.overwrite)
    if refused:
        print(f'mona-swarm animate: error: {refused}', file=sys.stderr)
        return 2
    started = time.perf_counter()
    with tqdm(unit='frame', desc='animate', disable=None, file=sys.stderr) as bar:
        def progress(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        try:
            written = animate(args.episode, args.out, speedup=args.speedup, fps=args.fps,
                              width=args.width, at=args.at, progress=progress)
        except (AnimateError, BagError) as error:
            bar.close()
            print(f'mona-swarm animate: error: {error}', file=sys.stderr)
            return 2
    size = f'{written["width"]}x{written["height"]}'
    took = f'in {time.perf_counter() - started:.1f} s'
    if args.out.suffix.lower() == '.png':
        print(f'{written["path"]}: a still ({size}) at t = {written["first_s"]:g} s of '
              f'{written["duration_s"]:g} s {took}')
    else:
        print(f'{written["path"]}: {written["frames"]} frames ({size}, {written["fps"]:g} fps) '
              f'of {written["duration_s"]:g} s at {written["speedup"]:g}x {took}')
    return 0


def _refused_output(out: Path, *, overwrite: bool) -> str | None:
    """Why ``out`` may not be written (None when it may): a folder, or a file already there
    (a video that took minutes to render is not replaced by a slip) without ``overwrite``."""
    if out.is_dir():
        return f"--out {out} is a folder: give the file's name (.mp4, .gif or .png)"
    if out.exists() and not overwrite:
        return f'--out {out} exists: choose another --out, or pass --overwrite to replace it'
    try:
        check_location(out, kind='file')  # under a file, /proc, read-only, not writable
    except OutputError as error:
        return str(error)
    return None
