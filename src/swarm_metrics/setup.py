from setuptools import find_packages, setup

package_name = 'swarm_metrics'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['numpy', 'numba', 'PyYAML', 'rosbags', 'mcap', 'mona_controller',
                      'swarm_world'],
    zip_safe=True,
    maintainer='Mona swarm developers',
    maintainer_email='mona-swarm@example.org',
    description=(
        'The metrics, recording and checking episodes (rosbag2/MCAP bags), plus the '
        'metrics node.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'metrics_node = swarm_metrics.ros.metrics_node:main',
        ],
    },
)
