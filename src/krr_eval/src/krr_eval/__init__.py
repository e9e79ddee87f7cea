"""Evaluation tools of the KRR-RL stack: run the paper's experiments headlessly, tabulate, plot.

The heavy lifting is done by the C++ core's command-line programs (built into
catkin_ws/devel/lib/krr_core); this package drives them, aggregates and plots.
"""
