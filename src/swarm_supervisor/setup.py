from glob import glob

from setuptools import find_packages, setup

package_name = 'swarm_supervisor'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    # The paper's claims (swarm_supervisor.analysis.claims reads them with importlib.resources,
    # beside the module: package data of the analysis sub-package).
    package_data={package_name + '.analysis': ['paper_claims.yaml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        # The shipped configuration (links into ros_ws/config: the default parameter file, the
        # Fast DDS profile, the Foxglove layout, the profiles of Monas, the learned controllers
        # with their weights), so that an installed package finds it without the source tree
        # (swarm_supervisor.config.shipped; the warm step runs the learned controllers).
        ('share/' + package_name + '/config',
         ['config/mona_swarm.yaml', 'config/fastdds_localhost.xml',
          'config/foxglove_layout.json']),
        ('share/' + package_name + '/config/profiles', sorted(glob('config/profiles/*.yaml'))),
        ('share/' + package_name + '/config/controllers',
         sorted(glob('config/controllers/*.yaml') + glob('config/controllers/*.npz'))),
    ],
    install_requires=[
        'numpy',
        'PyYAML',
        'tqdm',
        'matplotlib',
        'statsmodels',
        'pandas',
        'optuna',
        'mona_controller',
        'swarm_world',
        'swarm_metrics',
    ],
    zip_safe=True,
    maintainer='Mona swarm developers',
    maintainer_email='mona-swarm@example.org',
    description=(
        'Placement, episodes, the embedded runner, the study and the mona-swarm CLI, plus '
        'the supervisor node.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'supervisor_node = swarm_supervisor.system.ros.supervisor_node:main',
            'mona-swarm = swarm_supervisor.cli:main',
        ],
    },
)
