"""The run loop and what goes with it: the loop itself, what it records, what it writes,
checkpoints, the blow-up guard, progress bars and results folders."""
