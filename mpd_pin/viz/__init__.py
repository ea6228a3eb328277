"""Figures and 3-D replays: matplotlib plots, the meshcat replay page, workspace occupancy.

Nothing here changes a plan; every function draws what the other stages computed.
"""
