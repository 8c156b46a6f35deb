from setuptools import find_packages, setup

package_name = 'mona_controller'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['numpy'],
    zip_safe=True,
    maintainer='Mona swarm developers',
    maintainer_email='mona-swarm@example.org',
    description=(
        'The Mona controller: gradient following and BEECLUST stop-and-clean, plus its '
        'ROS node.'),
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'mona_controller_node = mona_controller.ros.controller_node:main',
        ],
    },
)
