"""What every node shares: the interface's names and the start-up parameter checks."""
