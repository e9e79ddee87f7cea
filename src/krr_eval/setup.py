# Only for catkin_python_setup() (CMakeLists.txt): do not run it by hand.
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=["krr_eval"], package_dir={"": "src"}))
