"""Every parameter file and design the project ships loads with the loader its top key names:
a plan that names a file that is not there (learned_heldout.yaml named controllers/solitary.yaml
after the file became solo.yaml) fails here, not hours into a comparison."""

from pathlib import Path

import pytest
import yaml

from swarm_supervisor.calibration.design import load_design as load_calibration
from swarm_supervisor.config import load_config
from swarm_supervisor.evolution.design import load_design as load_evolution
from swarm_supervisor.evolution.heldout import load_plan

CONFIG = Path(__file__).resolve().parents[2] / 'ros_ws' / 'config'
LOADERS = {'calibrate': load_calibration, 'evolve': load_evolution, 'heldout': load_plan,
           '/**': load_config}
#: Files another file names (its seeds), not loaded on their own.
INCLUDED = {'held_out_seeds.yaml'}
SHIPPED = sorted(path for path in CONFIG.rglob('*.yaml') if path.name not in INCLUDED)


def test_the_config_folder_is_found():
    assert len(SHIPPED) >= 15, SHIPPED


@pytest.mark.parametrize('path', SHIPPED, ids=lambda path: str(path.relative_to(CONFIG)))
def test_a_shipped_file_loads(path: Path):
    top = yaml.safe_load(path.read_text())
    keys = [key for key in top if key in LOADERS]
    assert len(keys) == 1, f'{path}: which loader? its top keys are {list(top)}'
    assert LOADERS[keys[0]](path) is not None
