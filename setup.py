from glob import glob

from setuptools import find_packages, setup

package_name = 'linkage_ros'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'bench']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/config/params', glob('config/params/*.yaml')),
        ('share/' + package_name + '/launch', glob('config/launch/*.launch.py')),
        ('share/' + package_name + '/rviz', glob('config/rviz/*.rviz')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='linkage_ros developers',
    maintainer_email='dev@linkage-ros.invalid',
    description='Planar closed-chain mechanism kinematics served over ROS 2 topics.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'linkage_node = linkage_ros.node:main',
            'linkage = linkage_ros.cli.parser:main',
        ],
    },
)
