"""Studies on top of the impact laws and the simulator: dissipation landscapes, the failure
atlas, the reproduction of the paper's examples and figures, and their plots."""
