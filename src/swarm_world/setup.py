from setuptools import find_packages, setup

package_name = 'swarm_world'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['numpy', 'pymunk', 'numba', 'rosbags', 'mona_controller'],
    zip_safe=True,
    maintainer='Mona swarm developers',
    maintainer_email='mona-swarm@example.org',
    description=(
        'The simulated world: arena, cue field, pymunk physics, Mona sensors, plus the '
        'world node.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'world_node = swarm_world.ros.world_node:main',
            'driver_node = swarm_world.ros.driver_node:main',
            'driver_hil = swarm_world.ros.hil:main',
        ],
    },
)
