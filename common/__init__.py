"""What every layer of the project may use: the one file writer."""
