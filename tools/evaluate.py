#!/usr/bin/env python3
"""Reproduce every experiment of the paper's Section IV headlessly (see --help).

    tools/evaluate.py --out out/eval [--quick | --trials-scale f | --trials exp2=N]
                      [--only exp1,exp2] [--workers W] [--scheduler tcp://host:8786]
                      [--replay DIR] [--seed S] [--ros | --no-ros]

Also runs as a ROS node (rosrun/roslaunch: private parameters _out:=DIR _quick:=true ...).
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from krr_eval import suite  # noqa: E402

if __name__ == "__main__":
    sys.exit(suite.main())
