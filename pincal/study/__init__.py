"""Studies on the model: simulation, pose selection, sensitivity statistics, Monte Carlo, zero offsets."""
