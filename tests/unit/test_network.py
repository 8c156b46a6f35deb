"""The network controller: its kernel equals the plain-Python reference bit for bit, a robot
computes the same commands alone and in batches of any size, and its weights parameters are
checked with errors naming the key."""

import dataclasses
import hashlib

import numpy as np
import pytest

from mona_controller.controllers import ControllerParams, make_controller, random_readings
from mona_controller.controllers.network import (
    CLEANING,
    NetworkController,
    NetworkParams,
    net_weights,
    top_command,
)
from mona_controller.controllers.network_forward import reference_forward
from mona_controller.controllers.network_weights import (
    MAX_HIDDEN,
    genome_size,
    save_weights,
    shapes,
    weights_from_genome,
)
from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError

K = MonaParams().ir_count


def network(**fields):
    """The controller section of the network kind with these of its parameters."""
    return ControllerParams.of(NetworkParams(**fields), kind='network')


def weights_file(tmp_path, hidden=4, recurrent=False, seed=0, name='w.npz', scale=1.0,
                 clean_bias=None):
    rng = np.random.default_rng(seed)
    size = genome_size(K, hidden, recurrent)
    weights = weights_from_genome(rng.normal(0.0, scale, size), K, hidden, recurrent)
    if clean_bias is not None:  # the cleaner output's bias: on some steps, off on others
        weights['b2'][2] = clean_bias
    path = tmp_path / name
    save_weights(path, weights)
    return path


@pytest.mark.parametrize('fair', [False, True])
@pytest.mark.parametrize('recurrent', [False, True])
@pytest.mark.parametrize('seed', [1, 2])
def test_the_kernel_equals_the_plain_python_reference_bit_for_bit(tmp_path, recurrent, seed,
                                                                  fair):
    hidden = 3 + 2 * seed
    # fair: wheels capped at 8 cm/s and no wheels while cleaning (the fair comparison).
    params = network(hidden=hidden, recurrent=recurrent,
                     weights=str(weights_file(tmp_path, hidden, recurrent, seed, scale=0.7,
                                              clean_bias=0.0)),
                     max_speed=0.08 if fair else 0.0, clean_stops=fair)
    mona = MonaParams(max_wheel_command=7.0, ir_range=0.05)
    top = top_command(params.network, mona)
    assert top == (0.08 / mona.wheel_unit_speed if fair else 7.0)
    n = 9
    controller = make_controller(params, mona, range(n))
    arrays = net_weights(params.network, mona)
    previous = [[0.0] * 3 for _ in range(n)]
    context = [[0.0] * MAX_HIDDEN for _ in range(n)]
    rng = np.random.default_rng(seed)
    cleaned, cleans, stood = set(), 0, 0
    for step in range(200):
        ground, ranges, is_robot = random_readings(rng, n, K)
        command = controller.step(ground, ranges, is_robot, step * 0.25)
        for i in range(n):
            left, right, clean = reference_forward(
                ground[i].tolist(), ranges[i].tolist(), is_robot[i].tolist(), arrays,
                mona.ir_range, top, previous[i], context[i], stops=fair)
            assert command.wheels[i].tobytes() == np.array([left, right]).tobytes(), (step, i)
            assert bool(command.cleaner[i]) == clean
            assert np.all(np.abs(command.wheels[i]) <= top)
            cleans += clean
            if clean and fair:
                assert command.wheels[i].tolist() == [0.0, 0.0]
                stood += 1
            assert controller.previous[i].tobytes() == np.array(previous[i]).tobytes()
            assert controller.context[i].tobytes() == np.array(context[i]).tobytes()
            cleaned.add(command.wheels[i].tobytes())
        assert controller.state.tolist() == [CLEANING if c else 0 for c in command.cleaner]
    assert len(cleaned) > 100  # the commands vary with the readings
    assert 0 < cleans < 200 * n  # both branches ran
    assert stood == (cleans if fair else 0)


@pytest.mark.parametrize('recurrent', [False, True])
def test_a_robot_alone_and_in_batches_of_1_5_and_64_gives_the_same_commands(tmp_path,
                                                                          recurrent):
    # Parts with different nets (files and seeds), widths and Monas, as a batch of episodes.
    paths = [weights_file(tmp_path, 2 + k % 5, recurrent, k, f'w{k}.npz') for k in range(4)]
    # Some parts capped and stopping to clean (the fair kind), some not.
    def params_of(k):
        fair = {'max_speed': 0.05 * (k % 2), 'clean_stops': k % 3 == 0}
        if k % 5 == 4:
            return network(seed=k, hidden=6, recurrent=recurrent, **fair)
        return network(hidden=2 + k % 5, recurrent=recurrent, weights=str(paths[k % 5]),
                       **fair)
    monas = [MonaParams(), MonaParams(max_wheel_command=6.0, ir_range=0.04)]
    sizes = [1, 5, 64]
    total = sum(sizes)
    lone = [make_controller(params_of(i % 5), monas[i % 2], [i]) for i in range(total)]
    parts = [make_controller(params_of(i % 5), monas[i % 2], [i]) for i in range(total)]
    batches, start = [], 0
    for size in sizes:
        batches.append(NetworkController.merge(parts[start:start + size]))
        start += size
    rng = np.random.default_rng(3)
    for step in range(150):
        ground, ranges, is_robot = random_readings(rng, total, K)
        alone = [c.step(ground[i:i + 1], ranges[i:i + 1], is_robot[i:i + 1], 0.0)
                 for i, c in enumerate(lone)]
        start = 0
        for size, batch in zip(sizes, batches):
            rows = slice(start, start + size)
            command = batch.step(ground[rows], ranges[rows], is_robot[rows],
                                 np.zeros(size))
            for j in range(size):
                own = alone[start + j]
                assert own.wheels.tobytes() == command.wheels[j:j + 1].tobytes(), (step, size)
                assert own.cleaner.tobytes() == command.cleaner[j:j + 1].tobytes()
            start += size


def test_the_weights_file_is_resolved_hashed_and_written_the_same_each_time(tmp_path,
                                                                          monkeypatch):
    path = weights_file(tmp_path)
    first = path.read_bytes()
    path.unlink()
    weights_file(tmp_path)
    assert path.read_bytes() == first  # fixed zip timestamps
    monkeypatch.chdir(tmp_path)
    params = network(hidden=4, weights='w.npz')
    assert params.network.weights == str(path)
    assert params.network.weights_sha256 == hashlib.sha256(first).hexdigest()
    # A copy of the section (to_mapping / from_mapping, a worker, a node) checks the hash.
    assert dataclasses.replace(params) == params
    assert ControllerParams().network.weights_sha256 == ''


def test_a_ctrl_c_while_the_weights_are_written_stays_a_ctrl_c(tmp_path, monkeypatch):
    """A signal handler's exception raised amid the archive's writing (here where zipfile
    sets up a member's compressor, where an interrupted evolution was seen to get it) reaches
    the caller as itself, not as zipfile's ValueError, and no file is written."""
    import zipfile

    weights = weights_from_genome(np.ones(genome_size(K, 4, False)), K, 4, False)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(zipfile, '_get_compressor', interrupted)
    with pytest.raises(KeyboardInterrupt):
        save_weights(tmp_path / 'w.npz', weights)
    assert not list(tmp_path.iterdir())


def test_bad_weights_are_refused_naming_the_key(tmp_path):
    def refused(match, **fields):
        with pytest.raises(ParameterError, match=match):
            make_controller(network(**fields), MonaParams(), [0])
    refused(r"controller.network.weights = '.*nowhere.npz': cannot read",
            weights=str(tmp_path / 'nowhere.npz'))
    path = weights_file(tmp_path, hidden=4)
    refused(r'network.weights = .*: w1 is \[4, 15\], a net of hidden = 5 needs '
            r'\[5, 15\]', weights=str(path), hidden=5)
    refused('lacks wr', weights=str(path), hidden=4, recurrent=True)
    recurrent = weights_file(tmp_path, hidden=4, recurrent=True, name='r.npz')
    refused('holds wr, not part of a net', weights=str(recurrent), hidden=4)
    refused('network.weights_sha256', weights=str(path), hidden=4, weights_sha256='0' * 64)
    with pytest.raises(ParameterError, match='w1 has 15 inputs, a Mona with 3 IR sensors'):
        make_controller(network(hidden=4, weights=str(path)), MonaParams(ir_count=3), [0])
    junk = tmp_path / 'junk.npz'
    junk.write_bytes(b'not a zip')
    refused('not an .npz', weights=str(junk))
    with pytest.raises(ValueError, match='a genome of 3 weights'):
        weights_from_genome([0.0] * 3, K, 4, False)
    assert genome_size(K, 4, True) == sum(np.prod(s) for s in shapes(15, 4, True).values())


def test_a_relative_weights_path_is_relative_to_the_parameter_file(tmp_path, monkeypatch):
    from swarm_supervisor.config import file_relative_overrides, load_config, write_ros_yaml
    from swarm_supervisor.system.preflight import run_overrides

    folder = tmp_path / 'configs'
    (folder / 'nets').mkdir(parents=True)
    path = weights_file(folder / 'nets')
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    params = folder / 'net.yaml'
    params.write_text('/**:\n  ros__parameters:\n    controller: {kind: network, '
                      'network: {hidden: 4, weights: nets/w.npz}}\n')
    elsewhere = tmp_path / 'elsewhere'
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # nothing named nets/w.npz here
    config = load_config(params)
    assert config.controller.network.weights == str(path)
    assert config.controller.network.weights_sha256 == digest
    # An absolute path still works, and a written file (absolute paths) reads back equal.
    write_ros_yaml(config, elsewhere / 'absolute.yaml')
    assert load_config(elsewhere / 'absolute.yaml') == config
    # The node system hands every node the resolved path (a node's --params-file cannot
    # tell it which file a value came from); the user's -p comes after it and wins.
    assert file_relative_overrides(params) == [f'controller.network.weights:={path}']
    assert file_relative_overrides(elsewhere / 'absolute.yaml') == []
    from swarm_supervisor.cli import launch as launch_cli

    options = launch_cli.build_parser().parse_args(['--config', str(params), '-p', 'x:=1'])
    assert run_overrides(options) == [f'controller.network.weights:={path}', 'x:=1']
    # Relative to the file, not the current directory: a file beside the cwd is not taken.
    monkeypatch.chdir(folder / 'nets')
    (folder / 'nets' / 'nets').mkdir()
    weights_file(folder / 'nets' / 'nets', seed=9)
    assert load_config(params).controller.network.weights_sha256 == digest
    missing = folder / 'missing.yaml'
    missing.write_text(params.read_text().replace('nets/w.npz', 'none/w.npz'))
    with pytest.raises(ParameterError, match=r"network.weights = '.*/configs/none/w.npz': "
                                             r'cannot read'):
        load_config(missing)


@pytest.mark.parametrize('name', ['evolved', 'evolved_fair'])
def test_the_shipped_evolved_controller_fits_the_design_that_made_it(tmp_path, monkeypatch,
                                                                     name):
    from pathlib import Path

    from swarm_supervisor.config import load_config
    from swarm_supervisor.evolution import load_design

    root = Path(__file__).resolve().parents[2]
    monkeypatch.chdir(tmp_path)  # its weights path is relative to the parameter file
    config = load_config(root / 'ros_ws' / 'config' / 'controllers' / f'{name}.yaml')
    design = load_design(root / 'ros_ws' / 'config' / 'designs' /
                         f'{name.replace("evolved", "evolve")}.yaml')
    assert config.controller.network.max_speed == design.max_speed
    assert config.controller.network.clean_stops == design.clean_stops
    assert config.controller.kind == 'network'
    assert config.controller.network.hidden == design.hidden
    assert config.controller.network.recurrent == design.recurrent
    arrays = net_weights(config.controller.network, config.mona)
    assert sum(a.size for a in arrays.values()) == design.genome_size
    make_controller(config.controller, config.mona, range(3))
