"""Scenario texts shared by the CLI, output and schema tests."""

#: The smallest energy scenario: the built-in two-link arm, a 30-node roadmap, the paper's
#: motor (the default), no obstacles.
SMALL_2LINK = """\
[arm]
builtin = "planar_2link"
[roadmap]
num_nodes = 30
k = 6
duration = 0.5
dt = 0.01
[task]
start = [0.3, 0.2]
goal = [1.2, -0.4]
"""
