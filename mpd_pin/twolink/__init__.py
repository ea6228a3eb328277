"""Two-link arm among moving obstacles (paper 002): IK, FCS maps, D* with stop/return, PSO."""
