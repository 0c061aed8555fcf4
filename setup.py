"""Build script for the tca_ros ament_python package."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'tca_ros'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/config/threads', glob('config/threads/*.yaml')),
        ('share/' + package_name + '/launch', glob('launch/*.launch.py')),
        ('share/' + package_name + '/rviz', glob('rviz/*.rviz')),
    ],
    package_data={package_name: [
        'data/*.csv', 'data/examples/*.csv', 'data/examples/README.md']},
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='tca_ros developers',
    maintainer_email='tca-ros@example.com',
    description='Twisted-and-coiled actuator simulator for ROS 2 (Cosserat rod, CST, Love).',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'tca_sim = tca_ros.cli.main:main',
            'tca_node = tca_ros.ros.node:main',
            'tca_pid = tca_ros.ros.pid_node:main',
        ],
    },
)
