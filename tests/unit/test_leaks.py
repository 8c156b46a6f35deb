"""Leaks beyond the paper: sources, emission, motion, loaded maps, diffusion and evaporation
(swarm_world.sources, transport, field), and the metrics that follow the sources."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError
from swarm_metrics.metrics import columns, sample
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import Episode
from swarm_supervisor.engine.runner import run_episode
from swarm_world import transport
from swarm_world.field import CueField, initial_cue
from swarm_world.params import WorldParams
from swarm_world.sensing.params import SensingParams
from swarm_world.sources import Source

#: Two moving, leaking sources on a diffusing, evaporating field (a small arena: fast).
LEAKS = {'arena_side': 1.2, 'cue_diameter': 1.0,
         'sources': {'west': [0.35, 0.6, 0.3, 255.0], 'east': [0.85, 0.6, 0.25, 200.0]},
         'source_profile': {'east': ['gaussian']},
         'source_emission': {'west': [20.0], 'east': [10.0]},
         'source_velocity': {'west': [0.01, 0.004]},
         'source_path': {'east': [0.02, 0.85, 0.3, 0.6, 0.2]},
         'diffusion': 2e-5, 'half_life': 300.0, 'transport_period': 0.5}


def leak_config(population: int = 12, duration: float = 20.0, seed: int = 3) -> SwarmConfig:
    return SwarmConfig().replace(world=LEAKS, episode={'population': population,
                                                        'duration': duration, 'seed': seed})


def gaussian_blob(cells: int, sigma_cells: float) -> np.ndarray:
    centres = np.arange(cells) - (cells - 1) / 2
    r2 = centres[None, :] ** 2 + centres[:, None] ** 2
    return (200.0 * np.exp(-0.5 * r2 / sigma_cells**2)).astype(np.float32)


def axis_variance(cue: np.ndarray, cell_size: float) -> float:
    """The variance (m^2) of the cue's distribution along x."""
    x = np.arange(cue.shape[1]) * cell_size
    weights = cue.astype(np.float64).sum(axis=0)
    mean = (weights * x).sum() / weights.sum()
    return float((weights * (x - mean) ** 2).sum() / weights.sum())


def test_diffusion_conserves_the_total_and_spreads_at_the_rate_its_coefficient_predicts():
    cell, diffusion, dt = 0.01, 1e-4, 1.0  # D dt / h^2 = 1: five substeps per update
    cue = gaussian_blob(121, 4.0)
    total, variance = cue.sum(dtype=np.float64), axis_variance(cue, cell)
    for _ in range(20):
        cue = transport.diffuse(cue, diffusion, dt, cell)
    assert cue.dtype == np.float32 and cue.min() >= 0
    assert cue.sum(dtype=np.float64) == pytest.approx(total, rel=1e-6)
    # A diffusing distribution's variance grows by 2 D t per axis (far from the walls).
    assert axis_variance(cue, cell) - variance == pytest.approx(2 * diffusion * 20 * dt,
                                                                rel=1e-3)
    # and its peak falls as 1 / (sigma^2 + 2 D t) in 2-D
    sigma2 = (4.0 * cell) ** 2
    assert cue.max() / 200.0 == pytest.approx(sigma2 / (sigma2 + 2 * diffusion * 20), rel=0.02)


def test_diffusion_is_stable_and_conserving_for_any_coefficient_and_walls():
    cue = np.zeros((40, 40), dtype=np.float32)
    cue[0, 0] = cue[39, 20] = 255.0  # mass against the walls and in a corner
    total = cue.sum(dtype=np.float64)
    for _ in range(5):
        cue = transport.diffuse(cue, 1.0, 1.0, 0.01)  # D dt / h^2 = 10,000
    assert np.all(np.isfinite(cue)) and cue.min() >= 0
    assert cue.sum(dtype=np.float64) == pytest.approx(total, rel=1e-5)
    assert cue.max() - cue.min() < 1e-3 * 255  # flat by now
    assert transport.diffusion_substeps(1.0, 1.0, 0.01) == 50_000


def test_evaporation_halves_the_cue_in_one_half_life():
    world = WorldParams(half_life=30.0, transport_period=0.5)
    field = CueField(world, MonaParams(), SensingParams())
    initial = field.cue.astype(np.float64)
    assert field.advance_to(30_000_000_000)  # 60 ticks of 0.5 s
    np.testing.assert_allclose(field.cue, initial / 2, rtol=1e-5, atol=1e-4)
    assert field.advance_to(60_000_000_000)
    np.testing.assert_allclose(field.cue, initial / 4, rtol=1e-5, atol=1e-4)


def test_emission_restores_the_profile_and_never_exceeds_it():
    world = WorldParams(sources={'leak': [1.4, 1.4, 0.5, 200.0]},
                        source_profile={'leak': ['gaussian']}, source_emission={'leak': [25.0]})
    field = CueField(world, MonaParams(), SensingParams())
    profile = field.initial.copy()
    field.cue[:] = 0.0  # cleaned away
    field.cue[140, 150] = 250.0  # above the profile here: left alone
    highest = []
    for k in range(1, 12):
        field.advance_to(k * 1_000_000_000)
        inside = np.ones_like(profile, dtype=bool)
        inside[140, 150] = False
        assert np.all(field.cue[inside] <= profile[inside])
        highest.append(float(field.cue[inside].max()))
    assert field.cue[140, 150] == 250.0
    # 25 cue units/s at the peak (scaled by the profile): linear until the profile is back
    top = float(profile.max())
    assert highest[:3] == pytest.approx([25 * top / 200, 50 * top / 200, 75 * top / 200],
                                        rel=1e-5)
    assert np.all(field.cue[profile == 0] == 0)
    restored = (profile > 0) & (np.arange(profile.shape[1])[None, :] != 150)
    np.testing.assert_array_equal(field.cue[restored], profile[restored])


def test_a_source_at_constant_velocity_reflects_at_the_walls():
    source = Source('s', 0.5, 1.0, 0.1, 100.0, velocity=(0.1, -0.05))
    assert source.position(0.0, 2.0) == (0.5, 1.0)
    assert source.position(10.0, 2.0) == pytest.approx((1.5, 0.5))
    assert source.position(20.0, 2.0) == pytest.approx((1.5, 0.0))  # x bounced at 2.0 m
    assert source.position(30.0, 2.0) == pytest.approx((0.5, 0.5))  # y bounced at 0
    assert source.position(40.0, 2.0) == pytest.approx((0.5, 1.0))  # one period on


def test_a_source_on_a_path_follows_its_waypoints_in_a_loop():
    source = Source('s', 0.0, 0.0, 0.1, 100.0, path_speed=0.5, path=((1.0, 0.0), (1.0, 1.0)))
    assert source.moves
    assert source.position(1.0, 5.0) == pytest.approx((0.5, 0.0))
    assert source.position(2.0, 5.0) == pytest.approx((1.0, 0.0))
    assert source.position(3.0, 5.0) == pytest.approx((1.0, 0.5))
    assert source.position(4.0, 5.0) == pytest.approx((1.0, 1.0))
    # half-way down the diagonal back to the start
    assert source.position(4.0 + math.sqrt(2), 5.0) == pytest.approx((0.5, 0.5))
    perimeter = 2.0 + math.sqrt(2)
    assert source.position(perimeter / 0.5, 5.0) == pytest.approx((0.0, 0.0), abs=1e-12)


def test_a_moving_leak_deposits_its_profile_where_it_is():
    world = WorldParams(arena_side=1.0, cue_diameter=0.5, sources={'a': [0.3, 0.5, 0.1, 255.0]},
                        source_velocity={'a': [0.04, 0.0]}, source_emission={'a': [1000.0]})
    field = CueField(world, MonaParams(), SensingParams())
    assert field.cue[50, 70] == 0.0 and field.cue[50, 50] == 0.0
    field.advance_to(10_000_000_000)  # 0.4 m to the right, at (0.7, 0.5)
    np.testing.assert_allclose(field.source_positions(10.0), [[0.7, 0.5]])
    assert field.cue[50, 69] > 230 and field.cue[50, 50] > 230  # where it is and has been
    assert field.cue[50, 85] == 0.0  # not yet ahead of it


def test_the_default_field_is_the_papers_disc_and_still():
    world = WorldParams()
    field = CueField(world, MonaParams(), SensingParams())
    assert world.paper_field and not field.dynamic and field.names == ('source',)
    cells = world.cells
    centres = (np.arange(cells) + 0.5) * world.cell_size
    distance = np.hypot(centres[None, :] - 1.425, centres[:, None] - 1.425)
    disc = (255.0 * np.clip(1.0 - distance / (2.227 / 2), 0.0, None)).astype(np.float32)
    assert np.array_equal(field.initial, disc)
    before = field.cue.copy()
    assert not field.advance_to(4000 * 10**9)
    assert np.array_equal(field.cue, before)


def test_sources_combine_by_their_highest_profile():
    world = WorldParams(sources={'a': [1.005, 1.405, 0.5, 255.0],
                                 'b': [1.605, 1.405, 0.5, 100.0]},
                        source_profile={'b': ['gaussian']})
    cue = initial_cue(world)  # cell (row 140, col 100) is centred on a, col 160 on b
    assert cue[140, 100] == 255.0 and cue[140, 160] == 100.0
    assert cue[140, 131] == pytest.approx(max(255 * (1 - 0.31 / 0.5),
                                              100 * math.exp(-0.5 * (0.29 * 6) ** 2)),
                                          rel=1e-5)
    assert cue[140, 175] == pytest.approx(100 * math.exp(-0.5 * (0.15 * 6) ** 2), rel=1e-5)
    assert cue[140, 230] == 0.0  # beyond both radii


def test_a_cue_map_loads_from_an_array_or_an_image(tmp_path):
    array = np.zeros((10, 20))
    array[0, :] = 255.0  # the first row is y = 0
    np.save(tmp_path / 'map.npy', array)
    world = WorldParams(arena_side=1.0, cue_file=str(tmp_path / 'map.npy'))
    cue = initial_cue(world)
    assert cue.shape == (100, 100) and cue.dtype == np.float32
    assert np.all(cue[:10] == 255.0) and np.all(cue[10:] == 0.0)
    pixels = np.zeros((50, 50), dtype=np.uint8)
    pixels[:5, :25] = 200  # the top left of the picture: far wall (+y), x < half
    Image.fromarray(pixels).save(tmp_path / 'map.png')
    cue = initial_cue(world.__class__(arena_side=1.0, cue_file=str(tmp_path / 'map.png')))
    assert np.all(cue[90:, :50] == 200.0) and cue[:90].max() == 0 and cue[:, 50:].max() == 0
    np.save(tmp_path / 'bad.npy', np.full((3, 3), 300.0))
    with pytest.raises(ValueError, match='0..255'):
        initial_cue(WorldParams(cue_file=str(tmp_path / 'bad.npy')))
    with pytest.raises(ValueError, match='no such file'):
        initial_cue(WorldParams(cue_file=str(tmp_path / 'missing.png')))



def test_a_relative_cue_file_is_relative_to_its_parameter_file(tmp_path, monkeypatch):
    from swarm_supervisor.config import file_relative_overrides, load_config

    folder = tmp_path / 'configs'
    (folder / 'maps').mkdir(parents=True)
    array = np.zeros((10, 10))
    array[:, :5] = 200.0  # the west half
    np.save(folder / 'maps' / 'leak.npy', array)
    params = folder / 'leak.yaml'
    params.write_text('/**:\n  ros__parameters:\n    world: {arena_side: 1.0, '
                      'cue_file: maps/leak.npy}\n')
    elsewhere = tmp_path / 'elsewhere'
    (elsewhere / 'maps').mkdir(parents=True)
    np.save(elsewhere / 'maps' / 'leak.npy', np.full((10, 10), 50.0))  # not this one
    monkeypatch.chdir(elsewhere)
    world = load_config(params).world
    assert world.cue_file == str(folder / 'maps' / 'leak.npy')
    cue = initial_cue(world)
    assert np.all(cue[:, :50] == 200.0) and cue[:, 50:].max() == 0.0
    # The node system hands the world node the resolved path too.
    assert file_relative_overrides(params) == [f'world.cue_file:={folder / "maps" / "leak.npy"}']

@pytest.mark.parametrize(('world', 'message'), [
    ({'sources': {'West': [1.0, 1.0, 0.5, 255.0]}}, 'lower-case identifier'),
    ({'sources': {'a': [1.0, 1.0, 0.5]}}, r'world.sources.a = .*expected 4 numbers'),
    ({'sources': {'a': [3.0, 1.0, 0.5, 255.0]}}, 'outside the 2.85 m arena'),
    ({'sources': {'a': [1.0, 1.0, 0.5, 300.0]}}, 'peak in 0..255'),
    ({'source_emission': {'b': [1.0]}}, r"world.source_emission.b: no source named 'b'"),
    ({'source_profile': {'source': ['cone']}}, 'expected \\[linear | gaussian\\]'),
    ({'source_path': {'source': [0.1, 1.0]}}, 'a path is'),
    ({'source_path': {'source': [0.1, 1.0, 9.0]}}, 'waypoint lies outside'),
    ({'diffusion': -1.0}, 'world.diffusion = -1.0 is out of range'),
    ({'source_velocity': {'source': [0.1, 0.0]}, 'source_path': {'source': [0.1, 1.0, 1.0]}},
     'a velocity or a path, not both'),
    ({'sources': {'source': [1.0, 1.0, 0.5, 255.0], 'b': [2.0, 1.0, 0.5, 255.0]}},
     "'source' names the paper's one source"),
])
def test_bad_leak_parameters_are_named(world, message):
    with pytest.raises(ParameterError, match=message):
        WorldParams(**world)


def test_the_episode_cue_equals_its_cleaning_record_replayed():
    """What the metrics node and bag analysis do: a fresh field fed the cleaning events, each
    after the transport ticks of the steps before it, equals the world's cue at every step."""
    episode = Episode(leak_config(population=14, duration=12.0))
    replica = CueField(episode.config.world, episode.config.mona,
                       episode.config.sensing)
    cleanings = 0
    while not episode.done:
        step = episode.step()
        if len(step.cleaned):
            replica.clean_at(step.time_ns, episode.world.poses[step.cleaned])
            cleanings += 1
        replica.advance_to(step.time_ns)
        assert np.array_equal(replica.cue, episode.world.cue), step.time_ns
    assert cleanings > 0
    assert not np.array_equal(episode.world.cue, episode.world.initial_cue)


def test_a_leak_episode_is_reproducible_and_has_per_source_columns():
    config = leak_config()
    first, again = run_episode(config), run_episode(config)
    assert first.metrics == again.metrics
    assert np.array_equal(first.final_cue, again.final_cue)
    assert list(first.metrics[0]) == list(columns(('east', 'west')))  # in name order
    for row in first.metrics:
        assert row['mean_cue_fraction_west'] + row['mean_cue_fraction_east'] == \
            pytest.approx(row['mean_cue_fraction'], rel=1e-9)
        assert row['ratio_near_west'] + row['ratio_near_east'] == \
            pytest.approx(row['ratio_near_source'])
    # the leaks keep the cue up against evaporation (emission runs) and it changes
    assert first.metrics[-1]['mean_cue'] != first.metrics[0]['mean_cue']


def test_near_the_nearest_source():
    sources = np.array([[0.0, 0.0], [10.0, 0.0]])
    robots = np.array([[0.5, 0.0], [9.0, 0.0], [5.0, 0.0]])
    cue = np.ones((4, 4), dtype=np.float32)
    row = sample(0.0, cue, 1.0, robots, sources, SwarmConfig().metrics, ('a', 'b'), 2.5)
    assert row['ratio_near_source'] == pytest.approx(1 / 3)  # r_c = 0.7 m: only the first
    assert row['ratio_near_a'] == pytest.approx(1 / 3) and row['ratio_near_b'] == 0.0
    # cells nearer to a (x < 5 m) hold 2 of the 4 columns of the raster
    assert row['mean_cue_fraction_a'] == pytest.approx(0.5)
