"""InstantNGP: NeRF snapshots (hash encoding, MLPs, occupancy) and its volume exports."""
